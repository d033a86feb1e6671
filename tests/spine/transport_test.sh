#!/usr/bin/env bash
# Two real processes exchange full-size stereo pairs (2 x 1360x1024 mono8) over UDP multicast on loopback at
# 8 Hz: every pair must arrive (no sequence gap) with identical contents (same checksum sum on both sides).
set -euo pipefail
BIN=$1; DATA=$2
U="udpm://239.255.76.67:7711?ttl=0"
N=40
out=$(mktemp)
"$BIN/bus_monitor" --lcm-url "$U" --channels STEREO --count $N --duration 30 --no-health > "$out" &
mon=$!
for i in $(seq 50); do grep -q ready "$out" && break; sleep 0.1; done
pub=$("$BIN/stereo_player" --lcm-url "$U" --left "$DATA/stereo/teddy/left.png" --right "$DATA/stereo/teddy/right.png" \
      --size 1360x1024 --count $N --rate 8 | tail -n 1)
wait $mon
echo "player:  $pub"; cat "$out"
sent_sum=${pub##*checksum=}
line=$(grep '^channel=STEREO' "$out")
[[ "$line" == *"received=$N "* ]] || { echo "FAIL: expected $N pairs"; exit 1; }
[[ "$line" == *"gaps=0 "* ]] || { echo "FAIL: sequence gaps"; exit 1; }
[[ "$line" == *"checksum=$sent_sum" ]] || { echo "FAIL: contents differ"; exit 1; }
echo "PASS: $N full-size pairs at 8 Hz, none dropped, contents identical"
