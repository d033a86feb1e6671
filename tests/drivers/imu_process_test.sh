#!/usr/bin/env bash
# The imu process against an emulated MMQ-50 on a pseudo-terminal: 400 packets at 200 Hz with flipped bytes,
# garbage runs and a silence in the middle of a packet. Every good packet must be published on IMU in order,
# every bad one counted in the health message, and the process must survive all of it.
set -euo pipefail
BIN=$1; CONFIG=$2
U="udpm://239.255.76.67:7741?ttl=0"
dir=$(mktemp -d); trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$dir"' EXIT
"$BIN/bus_monitor" --lcm-url "$U" --channels IMU --duration 8 > "$dir/mon" &
mon=$!
for i in $(seq 50); do grep -q ready "$dir/mon" && break; sleep 0.1; done
"$BIN/serial_emulator" --sensor mmq50 --config "$CONFIG" --link "$dir/tty" --count 400 --corrupt-every 40 \
  --garbage-every 30 --silence-at 200 --silence-s 0.3 --wait-s 1.0 > "$dir/emu" &
emu=$!
for i in $(seq 50); do grep -q ready "$dir/emu" && break; sleep 0.1; done
"$BIN/imu" --lcm-url "$U" --config "$CONFIG" --device "$dir/tty" 2> "$dir/imu.log" &
imu=$!
wait $emu
sleep 1.5
kill -TERM $imu; wait $imu || { echo "FAIL: imu exited with an error"; cat "$dir/imu.log"; exit 1; }
wait $mon
cat "$dir/emu" "$dir/mon"
# 400 sent: 10 with a flipped byte, 1 cut by the silence: 389 good ones published (the health counters are
# exact). The monitor may miss a few over UDP on a loaded machine; what it receives must be in order and valid.
line=$(grep '^channel=IMU' "$dir/mon")
received=$(sed -E 's/.*received=([0-9]+) .*/\1/' <<< "$line")
(( received >= 370 && received <= 389 )) || { echo "FAIL: expected about 389 samples on IMU, got $received"; exit 1; }
[[ "$line" == *"bad=0 "* && "$line" == *"backwards=0 "* ]] || { echo "FAIL: bad or backwards samples"; exit 1; }
grep -q "imu.published=389\|  *389  *389 " "$dir/mon" || { echo "FAIL: 389 samples must be published"; exit 1; }
grep -q "imu.frames=389$" "$dir/mon" || { echo "FAIL: frames counter"; exit 1; }
grep -q "imu.checksum_errors=10$" "$dir/mon" || { echo "FAIL: checksum errors not counted"; exit 1; }
grep -q "imu.partial_frames=1$" "$dir/mon" || { echo "FAIL: partial frame not counted"; exit 1; }
grep -Eq "imu.silences=[1-9]" "$dir/mon" || { echo "FAIL: silence not counted"; exit 1; }
grep -Eq "imu.garbage_bytes=[1-9]" "$dir/mon" || { echo "FAIL: garbage not counted"; exit 1; }
echo "PASS"
