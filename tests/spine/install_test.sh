#!/usr/bin/env bash
# cmake --install into a temporary prefix gives a system that runs from the prefix alone, nothing of the source or
# build tree on its PATH or in its working folder:
# - every program of the project that a deployment file (share/ips/procman/*.pmd) starts is in PREFIX/bin, and so
#   are the viewer, the mapper, calibrate_vignetting and ips_seeds;
# - a short simulated walk, played with the installed log_player through the installed tracker, filter and viewer
#   (configurations as the .pmd files name them, config/... under PREFIX/share/ips) and recorded with lcm-logger,
#   gives a complete run in the installed ips_report;
# - the viewer serves the installed page and the report fills the installed template (both copies are marked here,
#   so that the source tree's cannot pass for them).
#   install_test.sh BUILD_DIR [WORK]
set -euo pipefail
BUILD=$1
W=${2:-$(mktemp -d)}
rm -rf "$W"
mkdir -p "$W"
P=$W/prefix
cmake --install "$BUILD" --prefix "$P" >"$W/install.txt" || { cat "$W/install.txt"; echo "FAIL: cmake --install"; exit 1; }
fail=0

# The project's programs a deployment file starts (a word of an exec string that names a program of the build).
for pmd in "$P"/share/ips/procman/*.pmd; do
  for word in $(grep -o 'exec = ".*"' "$pmd" | tr -c 'a-z0-9_-' ' '); do
    if [ -x "$BUILD/bin/$word" ] && [ ! -x "$P/bin/$word" ]; then
      echo "FAIL: $(basename "$pmd") starts $word, which is not installed"
      fail=1
    fi
  done
done
for program in viewer mapper calibrate_vignetting ips_seeds procman-deputy procman-sheriff; do
  [ -x "$P/bin/$program" ] || { echo "FAIL: $program is not installed"; fail=1; }
done
[ -f "$P/share/ips/viewer/web/index.html" ] && [ -f "$P/share/ips/report/report_page.html" ] &&
  [ -f "$P/share/ips/config/tracker.yaml" ] ||
  { echo "FAIL: the viewer's page, the report's template or the configurations are not installed"; exit 1; }
marker="<!-- the installed copy $$ -->"
echo "$marker" >>"$P/share/ips/viewer/web/index.html"
echo "$marker" >>"$P/share/ips/report/report_page.html"

# The replay, from the prefix alone.
cd "$P/share/ips"
export PATH="$P/bin:/usr/bin:/bin"
U="udpm://239.255.76.67:7733?ttl=0"
PORT=18733
sim --duration 8 --seed 3 --out "$W/walk.lcmlog" --log-level warn
CALIB=$W/walk.lcmlog.calib.yaml
pids=()
cleanup() { kill -INT "${pids[@]}" 2>/dev/null || true; }
trap cleanup EXIT
tracker --lcm-url "$U" --calib "$CALIB" --config config/tracker.yaml --log-level warn &
pids+=($!)
filter --lcm-url "$U" --calib "$CALIB" --config config/filter_sim.yaml --log-level warn &
pids+=($!)
viewer --lcm-url "$U" --config config/viewer.yaml --port $PORT --bind 127.0.0.1 --log-level warn &
pids+=($!)
lcm-logger --lcm-url="$U" -c 'TRACKER_DELTA|FILTER_STATE|GT_POSE|HEALTH_.*' -f "$W/results.lcmlog" >/dev/null 2>&1 &
logger=$!
sleep 2 # every process subscribed
log_player --lcm-url "$U" --log "$W/walk.lcmlog" >/dev/null
page=$(python3 -c 'import sys, urllib.request; print(urllib.request.urlopen(sys.argv[1], timeout=10).read().decode())' \
  "http://127.0.0.1:$PORT/") || page=""
grep -qF "$marker" <<<"$page" || { echo "FAIL: the viewer did not serve the installed page"; fail=1; }
sleep 3 # the last pairs drain through the tracker and the filter
kill -INT "${pids[@]}"
wait "${pids[@]}" || true
pids=()
sleep 0.5
kill -INT $logger
wait $logger || true

ips_report --log "$W/results.lcmlog" --images "$W/walk.lcmlog" --calib "$CALIB" --out "$W/report" \
  >"$W/report.txt" 2>&1 || { cat "$W/report.txt"; echo "FAIL: ips_report from the prefix"; exit 1; }
report=$W/report/report.json
# Complete (an 8 s walk whose first 2 s are the filter's static start may be "disturbed": deltas before it started).
grep -q '"failures": \[\]' "$report" || { echo "FAIL: the replay from the prefix is not complete:"; cat "$report"; fail=1; }
grep -q '"tracker_deltas_valid": [1-9]' "$report" && grep -q '"states": [1-9]' "$report" ||
  { echo "FAIL: no tracker deltas or filter states in the replay from the prefix"; fail=1; }
grep -qF "$marker" "$W/report/report.html" || { echo "FAIL: the report did not fill the installed template"; fail=1; }
[ $fail = 0 ] && echo "PASS: installed into $P, the replay ran from there"
exit $fail
