#!/usr/bin/env bash
# The live page in a real browser: a short simulated walk plays (lcm-logplayer) through the real tracker,
# filter, e3d and mapper while the viewer serves the page to headless Chromium (live_page_check.py checks what the
# page shows); then the tracker is stopped and its row must turn red. Runs in its own network namespace.
set -euo pipefail
BIN=$1; SRC=$2; WORK=${3:-$(mktemp -d)}
U="udpm://239.255.76.67:7731?ttl=0"
mkdir -p "$WORK"; rm -f "$WORK"/{browsers_ready,live_checked,process_stopped}
# Long enough for a slow machine to start the browser and see everything while the walk plays.
"$BIN/sim" --duration 40 --out "$WORK/walk.lcmlog" --seed 3 > "$WORK/sim.txt"
CALIB="$WORK/walk.lcmlog.calib.yaml"
pids=()
cleanup() { kill -INT "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
"$BIN/tracker" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/tracker.yaml" --log-level warn & tracker=$!; pids+=($tracker)
"$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/filter_sim.yaml" --log-level warn & pids+=($!)
"$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$SRC/tests/system/e3d_small.yaml" --every-nth 2 --log-level warn & pids+=($!)
"$BIN/mapper" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/mapper.yaml" --log-level warn & pids+=($!)
"$BIN/viewer" --lcm-url "$U" --config "$SRC/config/viewer.yaml" --port 0 > "$WORK/viewer.txt" 2> "$WORK/viewer.err" & pids+=($!)
for _ in $(seq 100); do grep -q "serving http" "$WORK/viewer.txt" && break; sleep 0.1; done
url=$(grep -o 'http://[^ ]*' "$WORK/viewer.txt") || { echo "FAIL: the viewer printed no address"; cat "$WORK/viewer.err"; exit 1; }
echo "viewer at $url"
/usr/bin/python3 "$SRC/tests/viewer/live_page_check.py" --url "$url" --work "$WORK" \
  --processes tracker,filter,e3d,mapper,viewer --sources truth,EKF --stopped tracker & check=$!
for _ in $(seq 600); do [ -f "$WORK/browsers_ready" ] || ! kill -0 $check 2>/dev/null && break; sleep 0.2; done
lcm-logplayer --lcm-url="$U" "$WORK/walk.lcmlog" & player=$!; pids+=($player)
for _ in $(seq 1800); do [ -f "$WORK/live_checked" ] || ! kill -0 $check 2>/dev/null && break; sleep 0.1; done
# The others keep reporting their health (once a second, with or without input) while the page watches the
# tracker's row go red.
kill -INT $tracker; wait $tracker || true
touch "$WORK/process_stopped"
rc=0; wait $check || rc=$?
echo "screenshots: $WORK/viewer_live.png $WORK/viewer_stopped.png"
exit $rc
