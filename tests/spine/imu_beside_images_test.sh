#!/usr/bin/env bash
# Small messages beside full-size images on one LCM URL, on a loaded machine: 200 Hz IMU samples and 8 Hz
# 1360x1024 stereo pairs (2.8 MB each) published at once while two CPU hogs run; every IMU sample must arrive,
# in order, and every pair. Needs a network namespace of its own; run through netns_run.sh.
set -euo pipefail
BIN=$1; DATA=$2
U="udpm://239.255.76.67:7719?ttl=0"
out=$(mktemp)
hogs=()
trap 'kill "${hogs[@]}" $(jobs -p) 2>/dev/null || true; rm -f "$out"' EXIT
"$BIN/bus_monitor" --lcm-url "$U" --channels IMU,STEREO --duration 20 --count 2000 --no-health > "$out" &
mon=$!
for i in $(seq 50); do grep -q ready "$out" && break; sleep 0.1; done
for i in 1 2; do (while :; do :; done) & hogs+=($!); done
"$BIN/stereo_player" --lcm-url "$U" --left "$DATA/stereo/teddy/left.png" --right "$DATA/stereo/teddy/right.png" \
  --size 1360x1024 --count 80 --rate 8 > /dev/null &
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 2000 --period-ms 5
wait $mon
kill "${hogs[@]}"
cat "$out"
imu=$(grep '^channel=IMU' "$out")
[[ "$imu" == *"received=2000 "* && "$imu" == *"gaps=0 "* && "$imu" == *"backwards=0 "* ]] ||
  { echo "FAIL: IMU samples lost beside the images"; exit 1; }
echo "PASS: 2000 IMU samples at 200 Hz beside 8 Hz full-size pairs under load, none lost"
