#!/usr/bin/env bash
# The tilt process against an emulated PEI-Z260 on a pseudo-terminal: 100 lines at 50 Hz, every 10th corrupted,
# garbage runs, a silence in the middle of a line. Good lines are published on TILT, the rest counted.
set -euo pipefail
BIN=$1; CONFIG=$2
U="udpm://239.255.76.67:7742?ttl=0"
dir=$(mktemp -d); trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$dir"' EXIT
"$BIN/bus_monitor" --lcm-url "$U" --channels TILT --duration 7 > "$dir/mon" &
mon=$!
for i in $(seq 50); do grep -q ready "$dir/mon" && break; sleep 0.1; done
"$BIN/serial_emulator" --sensor z260 --config "$CONFIG" --rate 50 --link "$dir/tty" --count 100 --corrupt-every 10 \
  --garbage-every 15 --silence-at 50 --silence-s 0.8 --wait-s 1.0 > "$dir/emu" &
emu=$!
for i in $(seq 50); do grep -q ready "$dir/emu" && break; sleep 0.1; done
"$BIN/tilt" --lcm-url "$U" --config "$CONFIG" --device "$dir/tty" 2> "$dir/tilt.log" &
tilt=$!
wait $emu
sleep 1.5
kill -TERM $tilt; wait $tilt || { echo "FAIL: tilt exited with an error"; cat "$dir/tilt.log"; exit 1; }
wait $mon
cat "$dir/emu" "$dir/mon"
line=$(grep '^channel=TILT' "$dir/mon")
# 100 lines: 10 corrupted, 1 cut by the silence; garbage before a line spoils at most that line's start.
received=$(sed -E 's/.*received=([0-9]+) .*/\1/' <<< "$line")
(( received >= 78 && received <= 89 )) || { echo "FAIL: expected 80..89 samples, got $received"; exit 1; }
[[ "$line" == *"bad=0 "* && "$line" == *"backwards=0 "* ]] || { echo "FAIL: bad or backwards samples"; exit 1; }
frames=$(grep -E "tilt.frames=" "$dir/mon" | sed -E 's/.*=//')
(( received <= frames && received >= frames - 3 )) || { echo "FAIL: $frames good lines but $received samples on TILT"; exit 1; }
grep -q "tilt.partial_frames=1$" "$dir/mon" || { echo "FAIL: partial line not counted"; exit 1; }
grep -Eq "tilt.silences=[1-9]" "$dir/mon" || { echo "FAIL: silence not counted"; exit 1; }
bad=$(grep -E "tilt.(bad_frames|checksum_errors)=" "$dir/mon" | sed -E 's/.*=//' | paste -sd+ | bc)
garbage=$(grep -E "tilt.garbage_bytes=" "$dir/mon" | sed -E 's/.*=//')
(( bad + garbage > 0 )) || { echo "FAIL: corruption not counted"; exit 1; }
echo "PASS"
