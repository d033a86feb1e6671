#!/usr/bin/env bash
# A deputy killed with SIGKILL under a running sheriff: its children die with it (parent-death signal), and a
# new deputy of the same id gets its commands back from the sheriff's standing orders, without any action.
set -euo pipefail
BIN=$1; W=${2:-$(mktemp -d)}
mkdir -p "$W"; cd "$W"
export LCM_DEFAULT_URL="udpm://239.255.76.67:7731?ttl=0"
tag=$$  # the commands sleep 1000.<pid> and 1001.<pid> s: told apart from any other sleep
cat > restart.pmd <<PMD
cmd "first" {
    exec = "sleep 1000.$tag";
    deputy = "restarted";
}
cmd "second" {
    exec = "sleep 1001.$tag";
    deputy = "restarted";
}
script "run" {
    start cmd "first" wait "running";
    start cmd "second" wait "running";
    wait ms 600000;
}
PMD
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true; pkill -f "^sleep 100[01]\.$tag\$" 2>/dev/null || true' EXIT
"$BIN/procman-deputy" --id restarted > deputy1.log 2>&1 & deputy=$!; pids+=($deputy)
"$BIN/procman-sheriff" --config restart.pmd --script run --timeout 60 > sheriff.log 2>&1 & pids+=($!)
running() { pgrep -f "^sleep 100[01]\.$tag\$" | wc -l; }
for i in $(seq 300); do [ "$(running)" = 2 ] && break; sleep 0.1; done
[ "$(running)" = 2 ] || { echo "FAIL: the commands did not start"; cat sheriff.log; exit 1; }
old=$(pgrep -f "^sleep 100[01]\.$tag\$" | sort | paste -sd,)
kill -9 $deputy
for i in $(seq 100); do [ "$(running)" = 0 ] && break; sleep 0.1; done
[ "$(running)" = 0 ] || { echo "FAIL: the killed deputy's children live on"; exit 1; }
"$BIN/procman-deputy" --id restarted > deputy2.log 2>&1 & pids+=($!)
for i in $(seq 300); do [ "$(running)" = 2 ] && break; sleep 0.1; done
new=$(pgrep -f "^sleep 100[01]\.$tag\$" | sort | paste -sd,)
[ "$(running)" = 2 ] || { echo "FAIL: the new deputy did not get its commands back"; cat sheriff.log; exit 1; }
[ "$new" != "$old" ] || { echo "FAIL: the same processes?"; exit 1; }
echo "PASS: the killed deputy's children died with it; the new deputy runs both commands again ($old -> $new)"
