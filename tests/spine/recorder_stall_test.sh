#!/usr/bin/env bash
# log_recorder keeps every message across stalls: one recorder is stopped (SIGSTOP) twice, for 0.3 s and 0.2 s,
# while 2000 IMU samples come at about 1 kHz (10 and 7 times what LCM's default queue of 30 holds), a second one
# records the same stream untouched; both logs hold all 2000, byte for byte and in order (log_diff). An event
# still queued when the recorder is asked to stop is written too.
set -euo pipefail
BIN=$1
U="udpm://239.255.76.67:7719?ttl=0"
dir=$(mktemp -d)
trap 'kill $stalled $steady 2>/dev/null || true; rm -rf "$dir"' EXIT
"$BIN/log_recorder" --lcm-url "$U" --channels "IMU" --out "$dir/stalled.lcmlog" --increment > "$dir/stalled.out" &
stalled=$!
"$BIN/log_recorder" --lcm-url "$U" --channels "IMU" --out "$dir/steady.lcmlog" > "$dir/steady.out" &
steady=$!
sleep 0.5
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 2000 --period-ms 1 &
pub=$!
sleep 0.4
kill -STOP $stalled; sleep 0.3; kill -CONT $stalled
sleep 0.3
kill -STOP $stalled; sleep 0.2; kill -CONT $stalled
wait $pub
sleep 0.5
kill -INT $stalled $steady
wait $stalled $steady
cat "$dir/stalled.out" "$dir/steady.out"
[ -f "$dir/stalled.lcmlog.00" ] || { echo "FAIL: --increment did not write stalled.lcmlog.00"; exit 1; }
grep -q "^recorded=2000 events to $dir/stalled.lcmlog.00\$" "$dir/stalled.out" || { echo "FAIL: stalled recorder's count"; exit 1; }
diff=$("$BIN/log_diff" --channels IMU "$dir/stalled.lcmlog.00" "$dir/steady.lcmlog" || true)
echo "$diff"
[[ "$diff" == *"channel=IMU a=2000 b=2000 identical"* ]] || { echo "FAIL: the logs differ or lost samples"; exit 1; }
echo "PASS"
