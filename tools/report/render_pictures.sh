#!/usr/bin/env bash
# The run folder's PNG pictures, as screenshots of report.html (the same drawing as the page): one picture per
# section of the page (figures, trajectory_top, trajectory_side, trajectory_end, error_over_time, nees, tracker,
# disparity_<seq>, map_3d), each shown alone (report.html#only=<section>) in headless Chromium at the size the
# section asks for (its data-png attribute).
#
# Usage: render_pictures.sh REPORT_HTML [OUT_DIR]     (OUT_DIR: default the folder of REPORT_HTML)
# Prints the pictures written, one path a line. Exit 1 when Chromium is missing or the page did not draw
# (it names the page's console errors), 2 on bad arguments.
# Environment: CHROMIUM (default: chromium), IPS_RENDER_BUDGET_MS (the page's virtual time budget, default 20000:
# virtual time, so a loaded machine does not cut the drawing short).
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ] || [ ! -f "$1" ]; then
  echo "usage: $0 REPORT_HTML [OUT_DIR]  (REPORT_HTML: the page ips_report wrote)" >&2
  exit 2
fi
page=$(realpath "$1")
out=${2:-$(dirname "$page")}
mkdir -p "$out"
chromium=${CHROMIUM:-chromium}
command -v "$chromium" > /dev/null || { echo "$0: $chromium not found (apt-get install chromium)" >&2; exit 1; }
budget=${IPS_RENDER_BUDGET_MS:-20000}
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
flags=(--headless=new --user-data-dir="$profile" --hide-scrollbars --enable-unsafe-swiftshader
       --virtual-time-budget="$budget" --disable-gpu-shader-disk-cache)
# Chromium's sandbox refuses to run as root (containers, CI).
[ "$(id -u)" != 0 ] || flags+=(--no-sandbox)

# What the page drew: its sections and console errors, from #report-state.
state=$("$chromium" "${flags[@]}" --dump-dom "file://$page" 2> "$profile/chromium.err" |
        grep -o '<div id="report-state"[^>]*>' || true)
attr() { sed -n "s/.* $1=\"\\([^\"]*\\)\".*/\\1/p" <<< "$state" | sed 's/&quot;/"/g; s/&amp;/\&/g'; }
if [ "$(attr data-ready)" != 1 ]; then
  echo "$0: $page did not finish drawing in headless Chromium:" >&2
  tail -5 "$profile/chromium.err" >&2
  exit 1
fi
errors=$(attr data-errors)
if [ "$errors" != "[]" ]; then
  echo "$0: $page reported errors: $errors" >&2
  exit 1
fi
attr data-sections | python3 -c '
import json, sys
for s in json.load(sys.stdin):
    print(s["id"], s["png"].replace("x", ","))' |
while read -r id size; do
  "$chromium" "${flags[@]}" --window-size="$size" --screenshot="$out/$id.png" "file://$page#only=$id" \
    2> "$profile/chromium.err" > /dev/null
  if [ ! -s "$out/$id.png" ]; then
    echo "$0: no screenshot of section $id:" >&2
    tail -5 "$profile/chromium.err" >&2
    exit 1
  fi
  echo "$out/$id.png"
done
