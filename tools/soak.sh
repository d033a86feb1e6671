#!/usr/bin/env bash
# Soak: the main job's walk replayed three times in a row under procman, with one process killed by SIGKILL
# in each replay (tracker, the EKF filter, then the procman deputy itself, which an init system would start
# again: this script does). Checks after every replay:
#   - every process of the job was running until the end (procman respawned the killed one; after the
#     deputy's death the new deputy got its commands back),
#   - memory flat: the resident size of tracker, filters and e3d in the last third of the replay is at most
#     20 % above the first third's,
#   - the recording is complete and readable, and the report's figures are within their usual spread of the
#     replay without kills (end error at most 3 times its value), or the run is flagged as failed with the
#     reason (a killed deputy restarts the player and the logger: that run must be flagged).
# Usage: tools/soak.sh [SECONDS_BEFORE_EACH_KILL [VICTIMS]]   (VICTIMS default "tracker filter deputy";
# environment as tools/main_job.sh: IPS_DURATION, IPS_SEED)
# Runs in a network namespace of its own when it may (root), so that nothing else on the machine hears it.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
[ "${IPS_IN_NETNS:-}" = 1 ] || exec "$ROOT/tests/netns_run.sh" "$0" "$@"
KILL_AFTER_S=${1:-40}
VICTIMS=${2:-tracker filter deputy}
export PATH="$ROOT/build/bin:$PATH"
soak=$ROOT/out/soak_$(date -u +%Y%m%dT%H%M%SZ)
mkdir -p "$soak"
say() { printf '[soak] %s\n' "$*" | tee -a "$soak/soak.txt"; }

sim_args=(--out "$soak/walk.lcmlog" --gt-disparity-every 8 --seed "${IPS_SEED:-1}")
[ -n "${IPS_DURATION:-}" ] && sim_args+=(--duration "$IPS_DURATION")
say "simulating the walk once into $soak/walk.lcmlog"
sim "${sim_args[@]}" > "$soak/sim.txt" 2>&1
export IPS_SIM_LOG=$soak/walk.lcmlog

# One replay; $1: what to kill (none, tracker, filter, deputy). Leaves the run folder in $run.
replay() {
  local victim=$1 before after
  before=$(readlink "$ROOT/out/latest" 2>/dev/null || true)
  ./tools/main_job.sh > "$soak/main_job_$victim.txt" 2>&1 &
  local job=$!
  for _ in $(seq 600); do
    after=$(readlink "$ROOT/out/latest" 2>/dev/null || true)
    [ -n "$after" ] && [ "$after" != "$before" ] && break
    sleep 0.1
  done
  run=$ROOT/out/$after
  : > "$soak/rss_$victim.txt"
  local t=0 killed=0
  while kill -0 $job 2>/dev/null; do
    sleep 2; t=$((t + 2))
    # resident size [kB] of the job's long-running processes, summed
    ps -eo rss=,args= | awk -v run="$run" 'index($0, run) && $2 ~ /(tracker|filter|e3d)$/ {s += $1} END {print s + 0}' \
      >> "$soak/rss_$victim.txt"
    if [ $killed = 0 ] && [ $t -ge "$KILL_AFTER_S" ] && [ "$victim" != none ]; then
      killed=1
      case $victim in
        tracker) pkill -9 -f "^tracker --calib $run/" && say "  killed the tracker at ${t} s" ;;
        filter) pkill -9 -f "^filter --calib $run/.* --filter ekf" && say "  killed the EKF filter at ${t} s" ;;
        deputy)
          # the deputy runs with the job's environment; a new one started the same way takes over
          local dep env_file
          dep=$(pgrep -f "^procman-deputy --id mainjob" | head -1)
          env_file=$(tr '\0' '\n' < /proc/"$dep"/environ | grep -E '^(IPS_|LCM_DEFAULT_URL|PATH=)' || true)
          kill -9 "$dep" && say "  killed the procman deputy at ${t} s; starting a new one"
          sleep 2
          env $env_file procman-deputy --id mainjob > "$run/deputy2.log" 2>&1 &
          ;;
      esac
    fi
  done
  local rc=0
  wait $job || rc=$?
  pkill -f "^procman-deputy --id mainjob" 2>/dev/null || true  # the restarted one, if any
  say "  replay with '$victim' killed: main job exit $rc, run folder $run"
  last_rc=$rc
}

check_memory() {  # the last third of the samples at most 20 % above the first third
  python3 - "$1" <<'PY'
import sys
v = [int(x) for x in open(sys.argv[1]) if x.strip() and int(x) > 0]
if len(v) < 6:
    print("    memory: too few samples"); sys.exit(1)
n = len(v) // 3
first, last = max(v[:n]), max(v[-n:])
print(f"    memory of tracker, filters and e3d: {first / 1024:.0f} MB early, {last / 1024:.0f} MB late")
sys.exit(0 if last <= 1.2 * first else 1)
PY
}

fail=0
replay none
[ $last_rc = 0 ] || { say "FAIL: the replay without kills failed"; exit 1; }
base=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["end_error_m"])' "$run/report.json")
say "  baseline end error $base m"
check_memory "$soak/rss_none.txt" | tee -a "$soak/soak.txt" || { say "FAIL: memory grew"; fail=1; }
for victim in $VICTIMS; do
  replay $victim
  status=$(python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print(r["status"], r["end_error_m"])' \
    "$run/report.json" 2>/dev/null || echo "unreadable")
  say "  report: $status"
  case $status in
    unreadable) say "FAIL: no readable report after killing the $victim"; fail=1 ;;
    failed*)
      [ $last_rc != 0 ] || { say "FAIL: the report is failed but the main job exited 0"; fail=1; }
      python3 -c 'import json,sys; [print("    flagged:", f) for f in json.load(open(sys.argv[1]))["failures"]]' \
        "$run/report.json" | tee -a "$soak/soak.txt" ;;
    ok*|disturbed*)
      end=${status#* }
      python3 -c "import sys; sys.exit(0 if $end <= 3 * $base else 1)" ||
        { say "FAIL: end error $end m after killing the $victim, not flagged (baseline $base m)"; fail=1; }
      [ "$victim" != deputy ] || { say "FAIL: the deputy was killed and the run is not flagged"; fail=1; } ;;
  esac
  check_memory "$soak/rss_$victim.txt" | tee -a "$soak/soak.txt" || { say "FAIL: memory grew"; fail=1; }
  # every recording part readable: all of it, or (a logger killed with SIGKILL cannot finish its last write)
  # all but an incomplete last event
  for part in "$run"/results.lcmlog.[0-9]* "$run"/results_states.lcmlog.[0-9]*; do
    if ! err=$(log_diff --channels 'GT_POSE' "$part" "$part" 2>&1 >/dev/null); then
      size=$(stat -c %s "$part")
      if [[ "$err" =~ ([0-9]+)\ bytes\ at\ byte\ ([0-9]+)\ after\ event\ ([0-9]+) ]] &&
         [ $((BASH_REMATCH[1] + BASH_REMATCH[2])) = "$size" ]; then
        say "    $(basename "$part"): ${BASH_REMATCH[3]} events readable, the last one cut by the logger's death"
      else
        say "FAIL: $part is damaged: $err"; fail=1
      fi
    fi
  done
done
[ $fail = 0 ] && say "PASS: replays with the $VICTIMS killed: recovered or flagged, memory flat, recordings readable"
exit $fail
