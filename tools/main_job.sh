#!/usr/bin/env bash
# The main job on the built system: simulates the hard walk (sim writes an LCM log), starts a procman
# deputy on this machine and has the sheriff run procman/main_job.pmd (tracker, EKF and UKF filters, e3d and
# lcm-logger, with lcm-logplayer playing the walk through them), then writes the report to out/<run>/
# (out/latest points at it).
# Environment: IPS_VIEWER_PORT (port of the live view; default a free one, printed), IPS_DURATION (seconds of the
# walk; default the whole walk), IPS_SEED, IPS_SCENARIO (a sim scenario file instead of config/sim_hard.yaml, e.g.
# config/sim_walk.yaml for the easy walk), IPS_REPLAY_SPEED (default 1), IPS_CONFIG (the config folder; default
# config/; which file of it each process reads is chosen below, "2. configurations"),
# IPS_SIM_LOG (reuse a simulated log and its .calib.yaml instead of simulating), IPS_CALIB (a calibration file the
# processes run on instead of the log's; the log's is then the truth the report compares with), IPS_SEEDS (the
# job once per seed 1..N, summarised by ips_seeds), LCM_DEFAULT_URL.
# IPS_DATASET=DIR runs a public recording instead of the walk (EuRoC ASL folder, KITTI odometry folder or KITTI raw
# drive, told apart by layout): dataset_to_lcm writes it as the head's log with the head's IMU description, the
# tracker runs with the head's config (config/euroc.yaml, config/kitti.yaml), the filters when it has IMU, and the report adds the recording figures
# (relative errors over 1/2 m on EuRoC, 10/20/40 m on KITTI). IPS_DATASET_ARGS passes more options
# (e.g. "--first 0 --last 149").
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BIN=$ROOT/build/bin
export PATH="$BIN:$PATH"
# The walk is simulated as a real head meets it (config/sim_hard.yaml: a perturbed calibration, unknown stamp
# offsets, motion blur, auto exposure, people; processes/sim/README.md) unless another scenario is named;
# IPS_SCENARIO=config/sim_walk.yaml is the easy walk on the true head. A reused log or a recording keeps its own.
if [ -z "${IPS_DATASET:-}" ] && [ -z "${IPS_SIM_LOG:-}" ]; then
  export IPS_SCENARIO=${IPS_SCENARIO:-$ROOT/config/sim_hard.yaml}
fi
# IPS_SEEDS=N: the job once per seed 1..N (each its own out/<run>), then ips_seeds summarises them into
# out/<time>-seeds/seeds.json (end error mean, worst and spread per filter, NEES averaged over the seeds).
if [ "${IPS_SEEDS:-1}" -gt 1 ]; then
  seeds_dir=$ROOT/out/$(date -u +%Y%m%dT%H%M%SZ)-seeds
  mkdir -p "$seeds_dir"
  runs=()
  for seed in $(seq 1 "$IPS_SEEDS"); do
    echo "[main job] seed $seed of $IPS_SEEDS"
    IPS_SEEDS=1 IPS_SEED=$seed "$ROOT/tools/main_job.sh" "$@" || echo "[main job] seed $seed: the job failed (its report says why)"
    runs+=("$(readlink -f "$ROOT/out/latest")")
    ln -sfn "${runs[-1]}" "$seeds_dir/seed_$seed"
    # The simulated walk (about 3 GB) goes once its report is written: `sim --seed N` renders it again byte for
    # byte, and ten of them would fill a disk. IPS_KEEP_LOGS=1 keeps them.
    if [ "${IPS_KEEP_LOGS:-0}" != 1 ] && [ -f "${runs[-1]}/walk.lcmlog" ] && [ ! -L "${runs[-1]}/walk.lcmlog" ]; then
      rm -f "${runs[-1]}/walk.lcmlog"
      echo "[main job] seed $seed: its simulated walk removed (sim --seed $seed renders it again; IPS_KEEP_LOGS=1 keeps it)"
    fi
  done
  ips_seeds --runs "$(IFS=,; echo "${runs[*]}")" --out "$seeds_dir/seeds.json" | tee "$seeds_dir/seeds.txt"
  ln -sfn "$(basename "$seeds_dir")" "$ROOT/out/latest"
  exit "${PIPESTATUS[0]}"
fi
run=$ROOT/out/$(date -u +%Y%m%dT%H%M%SZ)
mkdir -p "$run"
ln -sfn "$(basename "$run")" "$ROOT/out/latest"
started=$(date +%s)
say() { printf '[main job %4ds] %s\n' $(( $(date +%s) - started )) "$*"; }
say "output in $run"

# 1. The sensor head: the simulated walk, as fast as the simulator can render it, or a recording.
export IPS_CONFIG=${IPS_CONFIG:-$ROOT/config}
report_args=()
if [ -n "${IPS_DATASET:-}" ]; then
  if [ -f "$IPS_DATASET/mav0/cam0/data.csv" ]; then format=euroc lengths=1,2 head=euroc
  elif [ -d "$IPS_DATASET/sequences" ]; then format=kitti lengths=10,20,40 head=kitti
  elif [ -f "$IPS_DATASET/oxts/timestamps.txt" ]; then format=kitti_raw lengths=10,20,40 head=kitti
  else say "IPS_DATASET=$IPS_DATASET is neither an EuRoC (mav0/cam0/data.csv), a KITTI odometry (sequences/) nor a KITTI raw (oxts/) folder"; exit 1
  fi
  say "1/4 converting the $format recording $IPS_DATASET (build/bin/dataset_to_lcm)"
  # shellcheck disable=SC2086
  dataset_to_lcm --format $format --in "$IPS_DATASET" --out "$run/walk.lcmlog" ${IPS_DATASET_ARGS:-} 2>&1 | tee "$run/dataset.txt" | sed -u 's/^/    /'
  [ "${PIPESTATUS[0]}" = 0 ] || exit 1
  report_args=(--lengths "$lengths")
  # Without IMU no filter runs: the map is placed by the tracker's increments, in the body frame at the first
  # image, which nothing levels. KITTI's body is camera 0 (x right, y down, z forward): up is -y; EuRoC's is its
  # IMU, and its ground truth (gravity-aligned) says where up is.
  if grep -q ", 0 IMU samples" "$run/dataset.txt"; then
    export IPS_MAPPER_POSES=tracker
    report_args+=(--map-poses tracker)
    if [ "$format" = kitti ]; then report_args+=(--map-up 0,-1,0); else report_args+=(--map-up truth); fi
  fi
elif [ -n "${IPS_SIM_LOG:-}" ]; then
  say "1/4 using the simulated log $IPS_SIM_LOG"
  ln -sf "$(realpath "$IPS_SIM_LOG")" "$run/walk.lcmlog"
  cp "$IPS_SIM_LOG.calib.yaml" "$run/walk.lcmlog.calib.yaml"
  [ ! -f "$IPS_SIM_LOG.true.calib.yaml" ] || cp "$IPS_SIM_LOG.true.calib.yaml" "$run/walk.lcmlog.true.calib.yaml"
else
  if [ -n "${IPS_SCENARIO:-}" ]; then say "1/4 simulating $IPS_SCENARIO (build/bin/sim)"
  else say "1/4 simulating the default walk (build/bin/sim; the paper's 90 m, 2 min indoor walk)"
  fi
  sim_args=(--out "$run/walk.lcmlog" --gt-disparity-every 8 --seed "${IPS_SEED:-1}")
  [ -n "${IPS_DURATION:-}" ] && sim_args+=(--duration "$IPS_DURATION")
  [ -n "${IPS_SCENARIO:-}" ] && sim_args+=(--scenario "$IPS_SCENARIO")
  sim "${sim_args[@]}" 2>&1 | sed -u 's/^/    /'
fi
# IPS_CALIB=FILE: the processes run on this calibration instead of the one that came with the log (for the
# simulated head: what the calibration tools estimated, tools/calib/calibrate_sim_head.sh); the log's own, the
# truth for a simulated head, goes beside it for the evaluation.
if [ -n "${IPS_CALIB:-}" ]; then
  [ -f "$IPS_CALIB" ] || { say "IPS_CALIB=$IPS_CALIB: no such file"; exit 1; }
  [ -f "$run/walk.lcmlog.true.calib.yaml" ] || cp "$run/walk.lcmlog.calib.yaml" "$run/walk.lcmlog.true.calib.yaml"
  cp "$IPS_CALIB" "$run/walk.lcmlog.calib.yaml"
  say "    the processes run on $IPS_CALIB"
fi
# Configurations: the one place that says which file each process reads. A recording runs with its head's tracker
# file (config/euroc.yaml, config/kitti.yaml), the filter's method for a real head (config/filter_recording.yaml;
# the head's IMU is in the recording's calibration) and E3D's recording settings; the simulated head with
# config/filter_sim.yaml and config/e3d_sim.yaml, or a scenario's own config/filter_<name>.yaml and
# config/e3d_<name>.yaml for config/sim_<name>.yaml where there are ones (a car's body vibration needs another
# process noise than a walker's gait; past plain walls the filters fuse the alignment of E3D's maps).
config_file() {  # the file $1 of the config folder, else $2 of it
  if [ -f "$IPS_CONFIG/$1" ]; then echo "$IPS_CONFIG/$1"; else echo "$IPS_CONFIG/$2"; fi
}
export IPS_MAPPER_CONFIG=$IPS_CONFIG/mapper.yaml IPS_VIEWER_CONFIG=$IPS_CONFIG/viewer.yaml
if [ -n "${IPS_DATASET:-}" ]; then
  export IPS_TRACKER_CONFIG=$IPS_CONFIG/$head.yaml IPS_FILTER_CONFIG=$IPS_CONFIG/filter_recording.yaml
  export IPS_E3D_CONFIG=$IPS_CONFIG/e3d_recording.yaml
else
  scenario_name=$(basename "${IPS_SCENARIO:-sim_hard.yaml}" .yaml)
  export IPS_TRACKER_CONFIG=$IPS_CONFIG/tracker.yaml
  IPS_FILTER_CONFIG=$(config_file "filter_${scenario_name#sim_}.yaml" filter_sim.yaml)
  IPS_E3D_CONFIG=$(config_file "e3d_${scenario_name#sim_}.yaml" e3d_sim.yaml)
  export IPS_FILTER_CONFIG IPS_E3D_CONFIG
fi
for process in tracker filter e3d mapper viewer; do
  var=IPS_$(echo $process | tr a-z A-Z)_CONFIG
  say "    $process reads ${!var#$ROOT/}"
done
walk_s=$(lcm-logplayer --help >/dev/null 2>&1; python3 - "$run/walk.lcmlog" <<'PY' 2>/dev/null || echo 0
import struct, sys
f = open(sys.argv[1], 'rb'); first = last = None
while True:
    h = f.read(28)
    if len(h) < 28: break
    sync, num, t, clen, dlen = struct.unpack('>IqqII', h)
    f.seek(clen + dlen, 1)
    first = t if first is None else first; last = t
print(int((last - first) / 1e6) if first else 0)
PY
)

# 2. A deputy on this machine, on the run's LCM URL, with the id procman/main_job.pmd names ("mainjob"; a
#    second main job on the same LCM URL is refused by the deputy's discovery, exit 2).
export LCM_DEFAULT_URL=${LCM_DEFAULT_URL:-udpm://239.255.76.67:7667?ttl=0}
# The bulk bus (images, dense maps) on the next port of the same group unless given: no process that reads the IMU
# has image datagrams in its socket (processes/framework/README.md, "Two buses").
if [ -z "${IPS_BULK_LCM_URL:-}" ]; then
  if [[ $LCM_DEFAULT_URL =~ ^(udpm://[^:]+:)([0-9]+)(.*)$ ]]; then
    IPS_BULK_LCM_URL="${BASH_REMATCH[1]}$(( BASH_REMATCH[2] + 1 ))${BASH_REMATCH[3]}"
  else
    IPS_BULK_LCM_URL=$LCM_DEFAULT_URL
  fi
fi
export IPS_BULK_LCM_URL
export IPS_RUN_DIR=$run IPS_REPLAY_SPEED=${IPS_REPLAY_SPEED:-1.0}
# The live view: IPS_VIEWER_PORT, else a port free on this machine (a fixed one may be taken by another job).
IPS_VIEWER_PORT=${IPS_VIEWER_PORT:-$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
export IPS_VIEWER_PORT
export IPS_MAPPER_POSES=${IPS_MAPPER_POSES:-filter}
deputy_id=mainjob
say "2/4 starting procman-deputy '$deputy_id' on $LCM_DEFAULT_URL (images and maps on $IPS_BULK_LCM_URL)"
procman-deputy --id "$deputy_id" > "$run/deputy.log" 2>&1 &
deputy=$!
trap 'kill -TERM $deputy 2>/dev/null || true; wait $deputy 2>/dev/null || true' EXIT

# 3. The sheriff runs the processing stages over the walk; progress every 15 s.
say "3/4 replaying ${walk_s} s of sensor data through tracker, filters (EKF, UKF) and e3d (procman/main_job.pmd)"
say "    live view: http://127.0.0.1:$IPS_VIEWER_PORT/ (open it in a browser on this machine while the walk plays)"
procman-sheriff --config procman/main_job.pmd --timeout 1800 --script run \
  > "$run/sheriff.log" 2>&1 &
sheriff=$!
while kill -0 $sheriff 2>/dev/null; do
  for _ in $(seq 15); do kill -0 $sheriff 2>/dev/null && sleep 1; done
  kill -0 $sheriff 2>/dev/null || break
  say "    replaying... (walk: ${walk_s} s at speed ${IPS_REPLAY_SPEED})"
  procman-sheriff --status --timeout 3 2>/dev/null | grep -E "^(DEPUTY|$deputy_id)" | awk '{printf "      %-10s %-9s %-15s %6s %6s\n", $2, $3, $4, $8, $9}' || true
done
if ! wait $sheriff; then
  say "the sheriff failed; its log:"; cat "$run/sheriff.log"; exit 1
fi
# (the deputy may be gone: killed, with another one started in its place that finished the job)
kill -TERM $deputy 2>/dev/null || true; wait $deputy 2>/dev/null || true
trap - EXIT

# 4. The report.
say "4/4 writing the report"
report_rc=0
# The logger writes results.lcmlog.00 (and .01, ... if it was restarted: ips_report then fails the run).
results=$(ls "$run"/results.lcmlog.[0-9]* 2>/dev/null | sort | paste -sd, -)
[ -n "$results" ] || { say "FAILED: no recording (results.lcmlog.*) in $run"; exit 1; }
results_states=$(ls "$run"/results_states.lcmlog.[0-9]* 2>/dev/null | sort | paste -sd, -)
[ -n "$results_states" ] && report_args+=(--states-log "$results_states")
results_bulk=$(ls "$run"/results_bulk.lcmlog.[0-9]* 2>/dev/null | sort | paste -sd, -)
[ -n "$results_bulk" ] && report_args+=(--bulk-log "$results_bulk")
# Evaluated against the truth when the processes ran on a perturbed calibration (sim with calibration_errors).
eval_calib=$run/walk.lcmlog.calib.yaml
[ ! -f "$run/walk.lcmlog.true.calib.yaml" ] || eval_calib=$run/walk.lcmlog.true.calib.yaml
# The maps, and on the simulated walk the world they are scored against (the one the simulator rendered).
[ -f "$run/map.ply" ] && report_args+=(--map "$run/map.ply")
[ -f "$run/map_gt_poses.ply" ] && report_args+=(--map-gt-poses "$run/map_gt_poses.ply")
if [ -z "${IPS_DATASET:-}" ] && [ -z "${IPS_SIM_LOG:-}" ]; then
  report_args+=(--world-seed "${IPS_SEED:-1}")
  [ -n "${IPS_SCENARIO:-}" ] && report_args+=(--world-scenario "$IPS_SCENARIO")
fi
ips_report --log "$results" --images "$run/walk.lcmlog" --calib "$eval_calib" \
  --process-calib "$run/walk.lcmlog.calib.yaml" --out "$run" "${report_args[@]}" > "$run/report.txt" || report_rc=$?
if [ ! -s "$run/report.json" ]; then
  say "FAILED: ips_report wrote no report (exit $report_rc)"; exit 1
fi
python3 - "$run/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
for e in r.get('estimators', []):
    print(f"  {e['name']}: ATE {e['ate_rmse_m']} m, RPE {e['rpe_trans_pct']} % and {e['rpe_rot_deg_per_m']} deg/m over {r['rpe_lengths_m']} m, end error {e['end_error_pct']} % (first pose aligned)")
print(f"  walk: {r['distance_m']:.1f} m in {r['duration_s']:.0f} s; tracker deltas {r['tracker_deltas_valid']}/{r['tracker_deltas']} valid")
print(f"  calibration the processes ran on: {r.get('calibration_source', 'unspecified')}")
for f in [f for f in r['filters'] if f['states']]:
    print(f"  {f['filter']}: end error {f['end_error_m']} m ({f['end_error_pct']} % of the distance), ATE RMSE {f['ate_rmse_m']} m")
print(f"  disparity: bad 2.0 {r['disparity_bad2_pct']} %, density {r['disparity_density_pct']} % ({r['disparity_maps_with_ground_truth']} maps with ground truth)")
if 'map_points' in r:
    line = f"  map: {r['map_points']} voxels (map.ply)"
    if 'map_median_surface_error_m' in r:
        line += f", to the true surfaces median {r['map_median_surface_error_m']:.3f} m, {r['map_within_5cm_pct']:.1f} % within 5 cm"
    if 'map_median_surface_error_m_gt_poses' in r:
        line += f" (true poses: {r['map_median_surface_error_m_gt_poses']:.3f} m, {r['map_within_5cm_pct_gt_poses']:.1f} %)"
    if r.get('map_consistency_median_m') is not None:
        line += f"; surfaces seen twice {r['map_consistency_median_m']:.3f} m apart (median)"
        if r.get('map_consistency_median_m_gt_poses') is not None:
            line += f", {r['map_consistency_median_m_gt_poses']:.3f} m with true poses"
    print(line)
for name, p in sorted(r['processes'].items()):
    print(f"  {name:12s} rate {p['rate_hz']:.2f} Hz, latency {p['latency_ms']:.1f} ms, dropped {p['dropped']}, bad {p['bad']}")
PY
if [ "$report_rc" != 0 ]; then
  # A process died, a state stream stopped or paused, or a recording is damaged: the figures above describe
  # part of the run, so the run is failed (report.json says why under "failures").
  python3 -c 'import json,sys; [print("FAILED:", f) for f in json.load(open(sys.argv[1]))["failures"]]' "$run/report.json"
  say "FAILED: $run/report.json (status failed, exit $report_rc)"; exit 1
fi
# The pictures are screenshots of the report page (the same drawing), by headless Chromium.
if ! tools/report/render_pictures.sh "$run/report.html" > "$run/pictures.txt" 2> "$run/pictures.err"; then
  say "FAILED: the report page's pictures (tools/report/render_pictures.sh):"; cat "$run/pictures.err"; exit 1
fi
say "done: $run/report.json, $run/report.html and $(wc -l < "$run/pictures.txt") pictures (trajectory_top.png, error_over_time.png, map_3d.png, ...)"
