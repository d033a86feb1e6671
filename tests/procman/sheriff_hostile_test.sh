#!/usr/bin/env bash
# Hostile procman messages into a running deputy and two running sheriffs (one giving orders, one following
# output), over LCM UDP multicast in a network namespace: every procman channel gets a valid message of the
# deputy with each 4-byte window replaced by a hostile length. All three keep running, say what they dropped,
# and keep working: the ordering sheriff still prints its table with the command running under its first pid,
# the follower still prints the command's output, and both end with exit 0.
# Usage: sheriff_hostile_test.sh BIN_DIR PROBE [WORK_DIR]
set -uo pipefail
BIN=$1; PROBE=$2; W=${3:-$(mktemp -d)}
mkdir -p "$W"; cd "$W"
export LCM_DEFAULT_URL="udpm://239.255.76.67:7732?ttl=0"
cat > hostile.pmd <<'PMD'
cmd "ticker" {
    exec = "sh -c 'i=0; while true; do echo tick $i; i=$((i+1)); sleep 0.1; done'";
    deputy = "h";
}
PMD
pids=()
trap 'kill -KILL "${pids[@]}" 2>/dev/null || true' EXIT
"$BIN/procman-deputy" --id h > deputy.log 2>&1 & deputy=$!; pids+=($deputy)
"$BIN/procman-sheriff" --config hostile.pmd --start ticker --wait running --status --keep-running --duration 600 \
  --status-period 0.5 --stop-on-exit > orders.txt 2> orders.err & sheriff=$!; pids+=($sheriff)
for i in $(seq 300); do grep -Eq '^h +ticker .* Running ' orders.txt && break; sleep 0.1; done
grep -Eq '^h +ticker .* Running ' orders.txt || { echo "FAIL: ticker did not start"; cat orders.txt orders.err; exit 1; }
pid_before=$(awk '$2 == "ticker" && NF == 10 { print $5; exit }' orders.txt)
"$BIN/procman-sheriff" --follow ticker --duration 600 > follow.txt 2> follow.err & follower=$!; pids+=($follower)
for i in $(seq 100); do grep -q '^tick' follow.txt && break; sleep 0.1; done

"$PROBE" --deputy h > probe.txt 2>&1 || { echo "FAIL: the probe did not run"; cat probe.txt; exit 1; }
cat probe.txt
# What each process printed up to the end of the attack; what comes after must show it still working.
tables_before=$(grep -c '^DEPUTY ' orders.txt)
ticks_before=$(grep -c '^tick' follow.txt)
sleep 2

fails=0
check() {  # check DESCRIPTION COMMAND...
  local what=$1; shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; fails=$((fails + 1)); fi
}
for p in deputy sheriff follower; do check "$p still running" kill -0 "${!p}"; done
check "ordering sheriff says it dropped PM_INFO" grep -q 'dropped a message on PM_INFO' orders.err
check "ordering sheriff says it dropped PM_OUTPUT" grep -q 'dropped a message on PM_OUTPUT' orders.err
check "deputy says it dropped PM_ORDERS" grep -q 'dropped a message on PM_ORDERS' deputy.log
check "ordering sheriff prints its table after the attack" test "$(grep -c '^DEPUTY ' orders.txt)" -gt "$tables_before"
pid_after=$(awk '$2 == "ticker" && NF == 10 { p = $5 } END { print p }' orders.txt)
status_after=$(awk '$2 == "ticker" && NF == 10 { s = $4 } END { print s }' orders.txt)
check "ticker running after the attack" test "$status_after" = Running
check "ticker kept its pid ($pid_before)" test "$pid_after" = "$pid_before"
check "follower prints output after the attack" test "$(grep -c '^tick' follow.txt)" -gt "$ticks_before"

kill -TERM "$follower"; wait "$follower"; check "follower exits 0" test $? -eq 0
kill -TERM "$sheriff"; wait "$sheriff"; check "ordering sheriff exits 0 (stopping what it ran)" test $? -eq 0
kill -TERM "$deputy"; wait "$deputy"; check "deputy exits 0" test $? -eq 0
if [ "$fails" -ne 0 ]; then
  for f in orders.err follow.err deputy.log; do echo "---- $f"; tail -20 "$f"; done
  echo "$fails check(s) failed"; exit 1
fi
echo "PASS: deputy and sheriffs survived $(awk -F= '{ s += $2 } END { print s }' probe.txt) hostile procman messages"
