#!/usr/bin/env bash
# Throughput of the camera process at full resolution: two fake GigE cameras (1360x1024 Mono8) at a given rate
# on loopback, the camera process, and bus_monitor counting STEREO. Prints pairs, rate, gaps and the process's
# per-pair latency. The fakes run on the same machine, so this is a lower bound of what the driver sustains.
# Needs root (a private network namespace); run under the build lock:
#   flock /tmp/ips-build.lock tools/drivers/camera_throughput.sh build/bin [rate_hz] [seconds]
set -euo pipefail
BIN=$(realpath "$1"); RATE=${2:-30}; SECONDS_RUN=${3:-12}
HERE=$(dirname "$(realpath "$0")"); ROOT=$(realpath "$HERE/../..")
if [ "${IPS_IN_NETNS:-}" != "1" ]; then exec "$ROOT/tests/netns_run.sh" "$0" "$BIN" "$RATE" "$SECONDS_RUN"; fi
ip addr add 127.0.0.2/8 dev lo; ip addr add 127.0.0.3/8 dev lo
dir=$(mktemp -d); trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$dir"' EXIT
sed -e "s/width: 640/width: 1360/; s/height: 480/height: 1024/; s/frame_rate_hz: 10.0/frame_rate_hz: $RATE/; s/packet_size: 1500/packet_size: 8000/" \
  "$ROOT/tests/drivers/camera_fake.yaml" > "$dir/camera.yaml"
U="udpm://239.255.76.67:7792?ttl=0"
DATA=$ROOT/../shared/data
"$BIN/fake_stereo_camera" --left-image "$DATA/stereo/teddy/left.png" --right-image "$DATA/stereo/teddy/right.png" > "$dir/fake" &
for i in $(seq 50); do grep -q ready "$dir/fake" && break; sleep 0.1; done
"$BIN/bus_monitor" --lcm-url "$U" --channels STEREO --duration $((SECONDS_RUN + 2)) > "$dir/mon" &
mon=$!
for i in $(seq 50); do grep -q ready "$dir/mon" && break; sleep 0.1; done
"$BIN/camera" --lcm-url "$U" --config "$dir/camera.yaml" 2> "$dir/camera.log" &
cam=$!
sleep "$SECONDS_RUN"
cpu=$(ps -o %cpu= -p $cam | tr -d ' ')
kill -TERM $cam; wait $cam || true
wait $mon
echo "rate_hz=$RATE size=1360x1024 run_s=$SECONDS_RUN camera_process_cpu_percent=$cpu"
grep -E '^channel=STEREO|^camera |camera\.(pairs|unpaired_left|unpaired_right|left_incomplete|right_incomplete|left_underruns|right_underruns)' "$dir/mon"
