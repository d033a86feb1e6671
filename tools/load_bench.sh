#!/usr/bin/env bash
# The load benchmark (a benchmark, not a test: its figures depend on the machine): the main job's replay of one log
# at replay speed 1.0, quiet and with a load beside it, and what the load cost navigation against the quiet run:
# IMU samples the filters lost (sequence gaps on their input), IMU gaps they bridged, pairs the tracker dropped
# (lost on the bus or stale), tracker deltas that came too late for the filters, and each filter's end error and ATE.
#
#   tools/load_bench.sh [--log FILE.lcmlog] [--duration S] [--loads quiet,browser,busy,build] [--speed 1.0]
#
# Without --log it simulates config/sim_rate20.yaml (a 20 Hz stereo + 200 Hz IMU head) for --duration seconds
# (default 70) once into out/load_bench/. Loads: browser (headless Chromium kept open on the live view from the start
# of the replay), busy (two busy loops at normal priority), build (this project built from scratch with -j2 into a
# scratch folder, again and again). Results: out/load_bench/<time>/bench.json and a table on stdout; each run's
# folder as the main job writes it.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
log="" duration=70 loads=quiet,browser,busy,build speed=1.0
while [ $# -gt 0 ]; do
  case "$1" in
    --log) log=$(realpath "$2"); shift ;;
    --duration) duration=$2; shift ;;
    --loads) loads=$2; shift ;;
    --speed) speed=$2; shift ;;
    *) echo "load_bench.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
bench=$ROOT/out/load_bench/$(date -u +%Y%m%dT%H%M%SZ)
mkdir -p "$bench"
if [ -z "$log" ]; then
  log=$ROOT/out/load_bench/rate20_${duration}s.lcmlog
  if [ ! -f "$log" ]; then
    echo "[load bench] simulating config/sim_rate20.yaml for $duration s into $log"
    build/bin/sim --scenario config/sim_rate20.yaml --duration "$duration" --gt-disparity-every 8 --out "$log" 2>&1 | tail -1
  fi
fi

load_pids=()
stop_load() {
  for p in "${load_pids[@]:-}"; do [ -n "$p" ] && kill -- -"$p" 2>/dev/null || kill "$p" 2>/dev/null || true; done
  load_pids=()
}
trap stop_load EXIT

start_load() {  # $1: the load, $2: the live view's port
  case "$1" in
    quiet) ;;
    busy)
      for _ in 1 2; do setsid sh -c 'while :; do :; done' & load_pids+=($!); done ;;
    build)
      setsid sh -c "while :; do rm -rf '$bench/scratch_build'; cmake -S '$ROOT' -B '$bench/scratch_build' -DCMAKE_BUILD_TYPE=Release >/dev/null && cmake --build '$bench/scratch_build' -j2 >/dev/null 2>&1; done" &
      load_pids+=($!) ;;
    browser)
      # Opened once the live view answers, as a user would open it, and kept open.
      setsid bash -c "until (exec 3<>/dev/tcp/127.0.0.1/$2) 2>/dev/null; do sleep 0.2; done; exec chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking --disable-component-update --disable-sync --user-data-dir='$bench/chromium_profile' --remote-debugging-port=0 http://127.0.0.1:$2/ >/dev/null 2>&1" &
      load_pids+=($!) ;;
    *) echo "load_bench.sh: unknown load '$1' (quiet, browser, busy, build)" >&2; exit 2 ;;
  esac
}

runs=()
for load in ${loads//,/ }; do
  port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  echo "[load bench] $load: replaying $log at speed $speed"
  start_load "$load" "$port"
  rc=0
  IPS_NO_SETUP=1 IPS_SIM_LOG=$log IPS_REPLAY_SPEED=$speed IPS_VIEWER_PORT=$port tools/main_job.sh > "$bench/$load.txt" 2>&1 || rc=$?
  stop_load
  run=$(readlink -f out/latest)
  ln -sfn "$run" "$bench/$load"
  runs+=("$load=$run")
  [ "$rc" = 0 ] || echo "[load bench] $load: the main job failed (its report says why: $run/report.json)"
done

python3 - "$bench/bench.json" "${runs[@]}" <<'PY'
import json, sys
out, runs = sys.argv[1], [r.split('=', 1) for r in sys.argv[2:]]
def figures(folder):
    try:
        r = json.load(open(folder + '/report.json'))
    except (OSError, ValueError):
        return None
    p = r.get('processes', {})
    c = lambda proc: p.get(proc, {}).get('counters', {})
    f = {'status': r.get('status'), 'failures': r.get('failures', []), 'warnings': r.get('warnings', []),
         'tracker_dropped': p.get('tracker', {}).get('dropped'), 'tracker_deltas': r.get('tracker_deltas')}
    for proc, name in (('filter', 'ekf'), ('filter_ukf', 'ukf')):
        f[name + '_imu_lost'] = c(proc).get('imu_seq_gap', 0)
        f[name + '_imu_gaps'] = c(proc).get('imu_gaps', 0)
        f[name + '_tracker_too_late'] = c(proc).get('tracker_too_late', 0)
    for e in r.get('filters', []):
        f[e['filter'] + '_end_error_m'] = e.get('end_error_m')
        f[e['filter'] + '_ate_m'] = e.get('ate_rmse_m')
    return f
table = {load: figures(folder) for load, folder in runs}
json.dump({'runs': dict(runs), 'figures': table}, open(out, 'w'), indent=1)
quiet = table.get('quiet') or {}
keys = ['tracker_deltas', 'tracker_dropped', 'ekf_imu_lost', 'ukf_imu_lost', 'ekf_imu_gaps', 'ekf_tracker_too_late',
        'ekf_end_error_m', 'ukf_end_error_m', 'ekf_ate_m', 'ukf_ate_m']
print('%-22s' % 'figure' + ''.join('%14s' % load for load, _ in runs))
for k in keys:
    row = '%-22s' % k
    for load, _ in runs:
        v = (table.get(load) or {}).get(k)
        s = '-' if v is None else (f'{v:.4f}' if isinstance(v, float) else str(v))
        if isinstance(v, float) and isinstance(quiet.get(k), float) and load != 'quiet' and quiet[k] > 0:
            s += f' ({100 * (v / quiet[k] - 1):+.0f}%)'
        row += '%14s' % s
    print(row)
for load, _ in runs:
    f = table.get(load) or {}
    if f.get('status') != 'ok' or f.get('warnings'):
        print(f"{load}: status {f.get('status')}; failures {f.get('failures')}; warnings {f.get('warnings')}")
print('bench:', out)
PY
