#!/usr/bin/env bash
# The camera process against two fake GigE Vision cameras (tools/drivers/fake_stereo_camera) serving the teddy
# pair: 30 stereo pairs must arrive on STEREO, valid, in order, their stamps on the cameras' 10 Hz grid (image
# contents are checked in test_drivers_camera). Needs a network namespace of its own (two loopback addresses); run through netns_run.sh.
set -euo pipefail
BIN=$1; CONFIG=$2; DATA=$3
if [ "${IPS_IN_NETNS:-}" != "1" ]; then echo "SKIP: needs a private network namespace (root)"; exit 77; fi
ip addr add 127.0.0.2/8 dev lo; ip addr add 127.0.0.3/8 dev lo
U="udpm://239.255.76.67:7743?ttl=0"
dir=$(mktemp -d); trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$dir"' EXIT
"$BIN/fake_stereo_camera" --left-image "$DATA/stereo/teddy/left.png" --right-image "$DATA/stereo/teddy/right.png" \
  > "$dir/fake" &
for i in $(seq 50); do grep -q ready "$dir/fake" && break; sleep 0.1; done
"$BIN/bus_monitor" --lcm-url "$U" --channels STEREO --count 30 --duration 30 > "$dir/mon" &
mon=$!
for i in $(seq 50); do grep -q ready "$dir/mon" && break; sleep 0.1; done
"$BIN/camera" --lcm-url "$U" --config "$CONFIG" 2> "$dir/camera.log" &
cam=$!
wait $mon
sleep 1.2  # one more health message
kill -TERM $cam; wait $cam || { echo "FAIL: camera exited with an error"; cat "$dir/camera.log"; exit 1; }
cat "$dir/mon"
line=$(grep '^channel=STEREO' "$dir/mon")
[[ "$line" == *"received=30 "* ]] || { echo "FAIL: expected 30 pairs"; cat "$dir/camera.log"; exit 1; }
[[ "$line" == *"bad=0 "* && "$line" == *"backwards=0 "* ]] || { echo "FAIL: bad or backwards pairs"; exit 1; }
# A frame can lose a packet over loopback on a loaded machine (the fake camera does not resend): its pair is
# dropped and shows as a gap. That is the network, not the driver; the driver must pair what arrives by the
# cameras' stamps, so the pairs it publishes lie on the cameras' 10 Hz grid whatever was lost in between.
gaps=$(sed -E 's/.*gaps=([0-9]+) .*/\1/' <<< "$line")
(( gaps <= 10 )) || { echo "FAIL: $gaps of 40 pairs lost"; exit 1; }
rate=$(sed -E 's/.*stamp_rate_hz=([0-9.]+).*/\1/' <<< "$line")
awk -v r="$rate" -v g="$gaps" 'BEGIN { grid = r * (29 + g) / 29; exit !(grid > 9.5 && grid < 10.5) }' ||
  { echo "FAIL: stamps at $rate Hz with $gaps pairs lost are not on the cameras' 10 Hz grid"; exit 1; }
grep -Eq "camera.left_frames=[1-9]" "$dir/mon" || { echo "FAIL: no camera health"; exit 1; }
echo "PASS"
