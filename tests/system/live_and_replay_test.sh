#!/usr/bin/env bash
# Live run, record and replay: the simulator publishes a short walk live through the real processes (tracker,
# filter, e3d, mapper) while lcm-logger records what they publish; then the same walk, written as a log, is played
# with lcm-logplayer through fresh processes, twice. All three recordings must hold identical tracker deltas,
# filter states, disparity maps and map points: every process takes time from message stamps only.
set -euo pipefail
BIN=$1; SRC=$2; WORK=${3:-$(mktemp -d)}
DURATION=${IPS_REPLAY_TEST_S:-12}
U="udpm://239.255.76.67:7721?ttl=0"
mkdir -p "$WORK"
"$BIN/sim" --duration "$DURATION" --out "$WORK/walk.lcmlog" --seed 7 > "$WORK/sim.txt"
CALIB="$WORK/walk.lcmlog.calib.yaml"
[ -f "$CALIB" ] || { echo "FAIL: the simulator wrote no calibration next to its log"; exit 1; }

run_once() {
  local out=$1 mode=${2:-replay}
  local pids=()
  "$BIN/tracker" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/tracker.yaml" --log-level warn & pids+=($!)
  "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/filter_sim.yaml" --log-level warn & pids+=($!)
  "$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$SRC/tests/system/e3d_small.yaml" --every-nth 4 --queue --log-level warn & pids+=($!)
  "$BIN/mapper" --lcm-url "$U" --calib "$CALIB" --config "$SRC/config/mapper.yaml" --log-level warn &
  local mapper=$!
  lcm-logger --lcm-url="$U" -c 'TRACKER_DELTA|FILTER_STATE|FILTER_PRIOR|DISPARITY|POINTS|HEALTH_.*' -f "$out" >/dev/null 2>&1 &
  local logger=$!
  sleep 2  # let every process subscribe (e3d builds its Vulkan pipeline)
  if [ "$mode" = live ]; then
    "$BIN/sim" --lcm-url "$U" --duration "$DURATION" --seed 7 --rate "${IPS_LIVE_RATE:-0.5}" \
      --calib-out "$WORK/live.calib.yaml" --log-level warn
    cmp -s "$WORK/live.calib.yaml" "$CALIB" || { echo "FAIL: live and batch calibrations differ"; exit 1; }
  else
    lcm-logplayer --lcm-url="$U" -e 'STEREO|IMU|TILT' "$WORK/walk.lcmlog"
  fi
  sleep 4  # the last pairs drain through tracker, filter and e3d
  kill -INT "${pids[@]}"
  wait "${pids[@]}" || true
  # The mapper last: e3d publishes what it still holds while it stops, and the mapper places it.
  sleep 1
  kill -INT $mapper; wait $mapper || true
  sleep 0.5
  kill -INT $logger; wait $logger || true
}

run_once "$WORK/live.lcmlog" live
run_once "$WORK/run1.lcmlog"
run_once "$WORK/run2.lcmlog"
channels='TRACKER_DELTA|FILTER_STATE|FILTER_PRIOR|DISPARITY|POINTS'
"$BIN/log_diff" --channels "$channels" "$WORK/run1.lcmlog" "$WORK/run2.lcmlog" | tee "$WORK/diff.txt" || true
"$BIN/log_diff" --channels "$channels" "$WORK/live.lcmlog" "$WORK/run1.lcmlog" | tee "$WORK/diff_live.txt" || true
for ch in TRACKER_DELTA FILTER_STATE FILTER_PRIOR DISPARITY POINTS; do
  grep -q "^channel=$ch a=[1-9]" "$WORK/diff.txt" || { echo "FAIL: no $ch messages recorded"; exit 1; }
done
grep -q '^identical=1' "$WORK/diff.txt" || { echo "FAIL: the two replays differ"; exit 1; }
grep -q '^identical=1' "$WORK/diff_live.txt" || { echo "FAIL: the replay differs from the live run"; exit 1; }
echo "PASS: the live run and two replays of a ${DURATION}s walk gave identical outputs"
