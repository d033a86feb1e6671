#!/usr/bin/env bash
# The real recording live equals the offline chain: EuRoC MH_01 frames 0-149 (stereo and the ADIS16448 at 200 Hz)
# played by log_player on the two buses through the tracker and both filters as processes, recorded by lcm-logger,
# gives the same tracker path and the same EKF and UKF states, every one of them, as navigate_log over the same log
# (the same estimators in one process, in stamp order). What it guards: the tracker waits for the filter's answer to
# every pair (a prior, or FILTER_PRIOR_NONE before the filter's start), so a pair never takes the gyro's prior in one
# run and the filter's in the next; the filters pace their states, so the recorder keeps the second of states a start
# in motion publishes at once; a process stopped after the player handles what reached it before, and the tracker
# stops before the filters, so that they fuse its last delta. Before: 0-160 states missing from the recording, the
# last pair or delta lost in some runs, the EKF's end error 0.23-0.24 % from run to run. Run through netns_run.sh.
set -euo pipefail
BIN=$1 SRC=$2 DATA=$3
IN=$DATA/euroc/MH_01_easy_first150
[ -d "$IN" ] || { echo "SKIP: $IN missing (see ../shared/data)"; exit 77; }
work=$(mktemp -d)
pids=()
cleanup() { kill -INT "${pids[@]}" 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
U="udpm://239.255.76.67:7731?ttl=0"
export IPS_BULK_LCM_URL="udpm://239.255.76.67:7732?ttl=0"
"$BIN/dataset_to_lcm" --format euroc --in "$IN" --out "$work/mh01.lcmlog" > /dev/null
CALIB=$work/mh01.lcmlog.calib.yaml
FILTER_CONFIG=$SRC/config/filter_recording.yaml TRACKER_CONFIG=$SRC/config/euroc.yaml

"$BIN/navigate_log" --log "$work/mh01.lcmlog" --tracker-config "$TRACKER_CONFIG" --filter-config "$FILTER_CONFIG" \
  --out "$work/offline.lcmlog" > /dev/null 2>&1

"$BIN/tracker" --lcm-url "$U" --calib "$CALIB" --config "$TRACKER_CONFIG" --log-level warn & pids+=($!)
tracker=$!
"$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$FILTER_CONFIG" --filter ekf --log-level warn & pids+=($!)
"$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$FILTER_CONFIG" --filter ukf --name filter_ukf \
  --state-channel FILTER_STATE_UKF --prior-channel none --log-level warn & pids+=($!)
lcm-logger --lcm-url="$U" -c 'TRACKER_DELTA|FILTER_STATE.*|GT_POSE|HEALTH_.*' -f "$work/live.lcmlog" > /dev/null 2>&1 &
logger=$!
sleep 2  # every process subscribed
"$BIN/log_player" --lcm-url "$U" --log "$work/mh01.lcmlog" --speed 0.5 --log-level warn
kill -INT $tracker
wait $tracker || true
kill -INT "${pids[@]}" 2>/dev/null || true
wait "${pids[@]}" || true
pids=()
sleep 0.5
kill -INT $logger
wait $logger || true

for run in offline live; do
  "$BIN/ips_report" --log "$work/$run.lcmlog" --calib "$CALIB" --lengths 1,2 --pictures 0 --out "$work/$run" \
    > "$work/$run.txt" 2>&1 || { cat "$work/$run.txt"; echo "FAIL: ips_report flags the $run run"; exit 1; }
done
python3 - "$work/live/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
if r['warnings']:
    sys.exit(f"FAIL: the live run was disturbed: {r['warnings']}")
PY
for f in trajectory_tracker.tum trajectory_FILTER_STATE.tum trajectory_FILTER_STATE_UKF.tum; do
  [ "$(wc -l < "$work/offline/$f")" -gt 100 ] || { echo "FAIL: the offline chain's $f is short"; exit 1; }
  cmp -s "$work/offline/$f" "$work/live/$f" ||
    { diff "$work/offline/$f" "$work/live/$f" | head -5; echo "FAIL: $f differs between live and offline"; exit 1; }
  echo "$f: $(($(wc -l < "$work/live/$f") - 1)) poses, live = offline"
done
echo PASS
