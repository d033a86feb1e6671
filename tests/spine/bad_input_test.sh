#!/usr/bin/env bash
# A running process fed undecodable bytes, NaN and time going backwards counts each kind, keeps running, and
# still receives the good messages that follow.
set -euo pipefail
BIN=$1
U="udpm://239.255.76.67:7713?ttl=0"
out=$(mktemp)
"$BIN/bus_monitor" --lcm-url "$U" --channels IMU --duration 6 --no-health > "$out" &
mon=$!
for i in $(seq 50); do grep -q ready "$out" && break; sleep 0.1; done
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 5 --period-ms 20 --bad garbage
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 4 --period-ms 20 --bad nan
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 10 --period-ms 20
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 3 --period-ms 20 --bad backwards
wait $mon
cat "$out"
line=$(grep '^channel=IMU' "$out")
# 4 NaN + 10 good + 3 backwards decode; the 5 garbage messages never reach the channel handler.
[[ "$line" == *"received=17 "* ]] || { echo "FAIL: received"; exit 1; }
[[ "$line" == *"bad=4 "* ]] || { echo "FAIL: NaN not counted"; exit 1; }
# the 3 'backwards' samples: the first repeats t=1 s, which is earlier than the good run's last stamp.
[[ "$line" == *"backwards=3 "* ]] || { echo "FAIL: backwards not counted"; exit 1; }
grep -q "decode_error=5 " "$out" || { echo "FAIL: garbage not counted"; exit 1; }
kill -0 $mon 2>/dev/null && { echo "FAIL: monitor still running"; exit 1; }
echo "PASS"
