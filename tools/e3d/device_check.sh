#!/usr/bin/env bash
# E3D on every Vulkan device of this machine, in one command: on each usable device (e3d_bench --list-devices) the
# E3D tests (every device stage, and the whole matcher, equal to its CPU reference: test_e3d_stages, test_e3d) and
# e3d_bench (census 640x480x128, 8 paths, beside OpenCV on the same pair; MI with 5 levels; census 1360x1024x128).
# A machine with a GPU gives its figures here; on one without, lavapipe's.
#
#   tools/e3d/device_check.sh [--build DIR] [--frames N] [--out DIR]
#
# Results: DIR (default out/device_check/<time>/): devices.txt, per device <index>_tests.txt and <index>_bench_*.txt,
# and summary.txt (also on stdout): per device its tests passed or failed and each benchmark's fps and ratio to
# OpenCV MODE_HH. Exit 1 when a device's tests fail.
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=build FRAMES=20 OUT=""
while [ $# -gt 0 ]; do
  case $1 in
    --build) BUILD=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    -h | --help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "device_check: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
BIN=$BUILD/bin
for program in e3d_bench test_e3d test_e3d_stages; do
  [ -x "$BIN/$program" ] || { echo "device_check: $BIN/$program is missing: build first" >&2; exit 2; }
done
OUT=${OUT:-out/device_check/$(date +%Y%m%d_%H%M%S)}
mkdir -p "$OUT"
"$BIN/e3d_bench" --list-devices | tee "$OUT/devices.txt"
field() { sed -n -E "s/(^|.* )$1=([^ ]*).*/\2/p" <<<"$2"; }
status=0
{
  printf '%-44s %-6s %-14s %-22s %-10s %-10s\n' device tests "census 640" "(E3D/OpenCV HH)" "MI 5 lvls" "1360x1024"
  while read -r line; do
    index=$(field device "$line")
    name=$(sed -n 's/.* name="\(.*\)"$/\1/p' <<<"$line")
    if [ "$(field usable "$line")" != 1 ]; then
      printf '%-44s unusable: %s\n' "$index $name" "$(sed -n 's/.* why="\([^"]*\)".*/\1/p' <<<"$line")"
      continue
    fi
    export IPS_VK_DEVICE=$index
    if "$BIN/test_e3d_stages" </dev/null >"$OUT/${index}_tests.txt" 2>&1 &&
      "$BIN/test_e3d" </dev/null >>"$OUT/${index}_tests.txt" 2>&1; then
      tests="passed"
    else
      tests="FAILED"
      status=1
    fi
    "$BIN/e3d_bench" --frames "$FRAMES" >"$OUT/${index}_bench_census640.txt" 2>&1 </dev/null || true
    "$BIN/e3d_bench" --frames "$FRAMES" --no-opencv --cost mi --mi-levels 5 >"$OUT/${index}_bench_mi5.txt" 2>&1 </dev/null || true
    "$BIN/e3d_bench" --frames "$FRAMES" --no-opencv --size 1360x1024 >"$OUT/${index}_bench_census1360.txt" 2>&1 </dev/null || true
    last() { tail -n 1 "$OUT/${index}_bench_$1.txt"; }
    printf '%-44s %-6s %-14s %-22s %-10s %-10s\n' "$index $name" "$tests" "$(field fps "$(last census640)") fps" \
      "($(field ratio_hh "$(last census640)")x)" "$(field fps "$(last mi5)") fps" "$(field fps "$(last census1360)") fps"
  done <"$OUT/devices.txt"
} >"$OUT/summary.txt"
cat "$OUT/summary.txt"
exit $status
