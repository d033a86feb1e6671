#!/usr/bin/env bash
# procman-sheriff's command line against a real procman-deputy over LCM UDP multicast (run in a network
# namespace by ctest): configuration checks, start/stop/restart of commands and groups, the status table,
# following output, scripts, taking over a deputy's state without disturbing it, and errors.
# Usage: sheriff_cli_test.sh BIN_DIR PROCMAN_SOURCE_DIR
set -uo pipefail
BIN=$1
SRC=$2
export LCM_DEFAULT_URL="udpm://239.255.76.67:7791?ttl=0"
WORK=$(mktemp -d /tmp/procman_cli.XXXXXX)
DEPUTY_PID=
cleanup() {
  [ -n "$DEPUTY_PID" ] && kill -KILL "$DEPUTY_PID" 2>/dev/null
  [ -n "${OTHER_PID:-}" ] && kill -KILL "$OTHER_PID" 2>/dev/null
  rm -rf "$WORK"
}
trap cleanup EXIT
fails=0
check() {  # check DESCRIPTION COMMAND...
  local what=$1
  shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; fails=$((fails + 1)); fi
}
sheriff() { "$BIN/procman-sheriff" --config "$WORK/test.pmd" --timeout 10 "$@"; }
# Column of a command's row in the status table: DEPUTY COMMAND GROUP STATUS PID RUN EXIT CPU% RSS_MB RESPAWN
col() { awk -v c="$1" -v n="$2" '$2 == c && NF == 10 { print $n }' "$3"; }

cat > "$WORK/test.pmd" <<'CFG'
group "g" {
    cmd "ticker" {
        exec = "sh -c 'i=0; while true; do echo tick $i; i=$((i+1)); sleep 0.1; done'";
        deputy = "cli";
        stop_signal = 15;
        stop_time_allowed = 2;
    }
    group "sub" {
        cmd "sleeper" { exec = "sleep 60"; deputy = "cli"; }
    }
}
cmd "crasher" { exec = "sh -c 'echo crashing; exit 4'"; deputy = "cli"; auto_respawn = "true"; }
cmd "once" { exec = "sh -c 'echo done once'"; deputy = "cli"; }
script "cycle" {
    start group "g" wait "running";
    wait ms 200;
    stop cmd "ticker" wait "stopped";
    wait group "g/sub" status "running";
    start cmd "once";
    wait cmd "once" status "stopped";
}
CFG

# Configuration checks (no LCM).
for f in system_local vehicle replay main_job; do
  check "config $f.pmd loads" "$BIN/procman-sheriff" --config "$SRC/$f.pmd" --check
done
"$BIN/procman-sheriff" --config "$WORK/test.pmd" --check > "$WORK/check.txt"
check "--check lists commands and scripts" grep -q 'cmd sleeper deputy=cli group=g/sub' "$WORK/check.txt"
printf 'cmd "x" {\n  exec = "y";\n  colour = "red";\n}\n' > "$WORK/bad.pmd"
"$BIN/procman-sheriff" --config "$WORK/bad.pmd" --start-all 2> "$WORK/bad.txt"
check "bad config: exit 1" test $? -eq 1
check "bad config: error names file and line" grep -q "bad.pmd:3:" "$WORK/bad.txt"

# No deputy yet: a start times out with exit 3 and names the deputy.
"$BIN/procman-sheriff" --config "$WORK/test.pmd" --timeout 1.5 --start-all 2> "$WORK/missing.txt"
check "missing deputy: exit 3" test $? -eq 3
check "missing deputy: named" grep -q "deputy cli" "$WORK/missing.txt"

"$BIN/procman-deputy" --id cli > "$WORK/deputy.log" 2>&1 &
DEPUTY_PID=$!
# Another deputy, run by another configuration: our sheriff must never order it.
"$BIN/procman-deputy" --id other > "$WORK/other.log" 2>&1 &
OTHER_PID=$!
printf 'cmd "foreign" { exec = "sleep 60"; deputy = "other"; }\n' > "$WORK/other.pmd"
"$BIN/procman-sheriff" --config "$WORK/other.pmd" --timeout 10 --start-all --wait running
check "other configuration started on deputy other" test $? -eq 0

# Start a group (with its subgroup); the deputy starts as soon as its discovery period is over.
sheriff --start g --wait running --status > "$WORK/s1.txt"
check "start group g: exit 0" test $? -eq 0
check "ticker running" test "$(col ticker 4 "$WORK/s1.txt")" = Running
check "sleeper (g/sub) running" test "$(col sleeper 4 "$WORK/s1.txt")" = Running
check "crasher not started" test "$(col crasher 6 "$WORK/s1.txt")" = 0
ticker_pid=$(col ticker 5 "$WORK/s1.txt")
sleeper_pid=$(col sleeper 5 "$WORK/s1.txt")

# Following output.
"$BIN/procman-sheriff" --follow ticker --duration 1.5 > "$WORK/follow.txt"
check "follow prints the command's output" grep -q "^tick [0-9]" "$WORK/follow.txt"

# A new sheriff takes over what runs without restarting it; starting another command leaves the rest alone.
sheriff --start crasher --status > "$WORK/s2.txt"
check "start crasher: exit 0" test $? -eq 0
check "ticker kept its pid" test "$(col ticker 5 "$WORK/s2.txt")" = "$ticker_pid"
check "sleeper kept its pid" test "$(col sleeper 5 "$WORK/s2.txt")" = "$sleeper_pid"
check "crasher respawn flag" test "$(col crasher 10 "$WORK/s2.txt")" = yes
sleep 1.5
"$BIN/procman-sheriff" --status > "$WORK/s3.txt"   # observer: no configuration, no orders
check "observer sees the crasher respawning (run id stays 1)" test "$(col crasher 6 "$WORK/s3.txt")" = 1
check "observer marks commands it does not know" grep -q "not in this configuration" "$WORK/s3.txt"
check "crasher exit status reported" grep -Eq 'crasher .* exit\(4\) ' "$WORK/s3.txt"

# Restart a subgroup by path: new pid and run id for sleeper only.
sheriff --restart g/sub --wait running --status > "$WORK/s4.txt"
check "restart g/sub: exit 0" test $? -eq 0
check "sleeper restarted (run 2)" test "$(col sleeper 6 "$WORK/s4.txt")" = 2
check "sleeper has a new pid" test "$(col sleeper 5 "$WORK/s4.txt")" != "$sleeper_pid"
check "ticker untouched (run 1)" test "$(col ticker 6 "$WORK/s4.txt")" = 1

# Sheriffs that restart another command take over a crash-looping auto-respawn command between two of its
# runs (pid 0): they must leave it respawning, not stop it.
for i in 1 2 3; do sheriff --restart g/sub --wait running > /dev/null; done
"$BIN/procman-sheriff" --follow crasher --duration 3 > "$WORK/crasher.txt"
check "crasher still respawning after three sheriffs restarted another command" grep -q '^crashing' "$WORK/crasher.txt"
sheriff --status > "$WORK/s4b.txt"
check "crasher not being stopped" test "$(col crasher 4 "$WORK/s4b.txt")" != Stopping

# Stop with the configured signal.
sheriff --stop ticker --status > "$WORK/s5.txt"
check "stop ticker: exit 0" test $? -eq 0
check "ticker stopped OK" test "$(col ticker 4 "$WORK/s5.txt")" = "Stopped(OK)"
check "ticker ended by its stop signal (SIGTERM)" test "$(col ticker 7 "$WORK/s5.txt")" = SIGTERM

# A script with waits.
sheriff --script cycle --status > "$WORK/s6.txt"
check "script cycle: exit 0" test $? -eq 0
check "script prints its actions" grep -q 'script cycle: wait cmd "once" status "stopped"' "$WORK/s6.txt"
check "once ran" test "$(col once 4 "$WORK/s6.txt")" = "Stopped(OK)"
check "ticker stopped by the script" test "$(col ticker 4 "$WORK/s6.txt")" = "Stopped(OK)"
check "ticker was started again by the script (run 2)" test "$(col ticker 6 "$WORK/s6.txt")" = 2

# Staying: orders every second, the table every 0.5 s, and everything stopped on the way out.
sheriff --start ticker --keep-running --duration 1.6 --status-period 0.5 --stop-on-exit > "$WORK/keep.txt"
check "keep-running: exit 0" test $? -eq 0
check "keep-running prints the table periodically" test "$(grep -c '^DEPUTY  *COMMAND' "$WORK/keep.txt")" -ge 2
check "keep-running showed ticker running" grep -Eq '^cli +ticker +g +Running ' "$WORK/keep.txt"
"$BIN/procman-sheriff" --status > "$WORK/s6b.txt"
check "stop-on-exit stopped everything" test "$(col sleeper 5 "$WORK/s6b.txt")" = 0

# Unknown names are errors.
sheriff --start nosuch 2> "$WORK/nosuch.txt"
check "unknown command: exit 1" test $? -eq 1
check "unknown command: named" grep -q "nosuch" "$WORK/nosuch.txt"

# Stop everything; the deputy stays up and reports the commands stopped.
sheriff --stop-all --status > "$WORK/s7.txt"
check "stop-all: exit 0" test $? -eq 0
for c in ticker sleeper crasher once; do
  check "$c stopped" test "$(col "$c" 5 "$WORK/s7.txt")" = 0
done
check "deputy still running" kill -0 "$DEPUTY_PID"
"$BIN/procman-sheriff" --status > "$WORK/s8.txt"
check "the other deputy's command survived all of it" grep -Eq '^other +foreign +- +Running\* ' "$WORK/s8.txt"
kill -TERM "$OTHER_PID"
wait "$OTHER_PID"

kill -TERM "$DEPUTY_PID"
wait "$DEPUTY_PID"
check "deputy exits 0 on SIGTERM" test $? -eq 0
DEPUTY_PID=

if [ "$fails" -ne 0 ]; then
  echo "---- deputy log"; cat "$WORK/deputy.log"
  for f in "$WORK"/s*.txt; do echo "---- $f"; cat "$f"; done
  echo "$fails check(s) failed"
  exit 1
fi
echo "all sheriff checks passed"
