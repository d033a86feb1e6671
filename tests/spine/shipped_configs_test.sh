#!/usr/bin/env bash
# Every configuration file the project ships, read by the process that reads it (--check-config): each of its keys
# must be a setting of that process, so a stale or misspelled key in a shipped file cannot sit there doing nothing.
# And a misspelled key in a user's copy is refused, naming the file and the key. Each process's --print-config (the
# settings it runs with, defaults included) is read back by the same process to the same settings.
#   shipped_configs_test.sh BIN_DIR CONFIG_DIR
set -uo pipefail
BIN=$1
CONFIG=$2
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
"$BIN/sim" --duration 0 --calib-out "$W/head.calib.yaml" --log-level error || { echo "FAIL: no calibration"; exit 1; }
head=(--calib "$W/head.calib.yaml")
fail=0
# check FILE [MODE] [AS]: MODE (--check-config, or --print-config) on FILE by the process that reads AS (default
# FILE); prints the process's answer
check() {
  local file=$1 mode=${2:---check-config} name
  name=$(basename "${3:-$file}")
  case $name in
    tracker.yaml | euroc.yaml | kitti.yaml) "$BIN/tracker" "$mode" --config "$file" "${head[@]}" ;;
    filter*.yaml) "$BIN/filter" "$mode" --config "$file" "${head[@]}" ;;
    e3d*.yaml) "$BIN/e3d" "$mode" --config "$file" "${head[@]}" ;;
    mapper*.yaml) "$BIN/mapper" "$mode" --config "$file" "${head[@]}" ;;
    viewer*.yaml) "$BIN/viewer" "$mode" --config "$file" ;;
    camera*.yaml) "$BIN/camera" "$mode" --config "$file" ;;
    imu*.yaml) "$BIN/imu" "$mode" --config "$file" ;;
    tilt*.yaml) "$BIN/tilt" "$mode" --config "$file" ;;
    sim_*.yaml) [ "$mode" = --check-config ] &&
      "$BIN/sim" --scenario "$file" --duration 0 --calib-out "$W/scenario.calib.yaml" --log-level error &&
      echo "$file: every key is a setting of the simulator" ;;
    *)
      echo "no process is known to read $name: add it to this test"
      return 1
      ;;
  esac
}
n=0
for f in "$CONFIG"/*.yaml; do
  if ! out=$(check "$f" 2>&1); then
    echo "FAIL: $out"
    fail=1
  fi
  n=$((n + 1))
done
echo "$n shipped files checked"

# --print-config: the settings in use, read back by the same process to the same settings (comments aside: they
# mark defaults, which the printed file then holds as values). A process may read more keys of a section the file
# now holds (e3d reads mono's keys once there is a mono section): every setting printed first must be there, with
# its value, and the second print must read back to itself. A value of the file is printed unmarked; a default is
# marked.
# settings: one line per setting, its full key path and value, sorted
settings() {
  sed -e 's/ *#.*$//' -e '/^ *$/d' -e '/^%YAML/d' | awk '
    { match($0, /^ */); depth = RLENGTH / 2; line = substr($0, RLENGTH + 1)
      key = line; sub(/:.*/, "", key); value = line; sub(/^[^:]*: ?/, "", value)
      path[depth] = key; full = path[0]; for (i = 1; i <= depth; ++i) full = full "/" path[i]
      if (value != "") print full ": " value }' | sort
}
np=0
for f in "$CONFIG"/*.yaml; do
  case $(basename "$f") in sim_*) continue ;; esac
  if ! first=$(check "$f" --print-config 2>&1); then
    echo "FAIL: --print-config on $f: $first"
    fail=1
    continue
  fi
  printf '%s\n' "$first" >"$W/printed.yaml"
  again=$(check "$W/printed.yaml" --print-config "$f" 2>&1) && printf '%s\n' "$again" >"$W/printed2.yaml" &&
    third=$(check "$W/printed2.yaml" --print-config "$f" 2>&1)
  missing=$(comm -23 <(settings <<<"$first") <(settings <<<"$again"))
  if [ -n "$missing" ] || [ "$(settings <<<"$again")" != "$(settings <<<"${third:-}")" ]; then
    echo "FAIL: $f's printed settings do not read back to themselves:"
    printf '%s\n' "$missing" | head -10
    diff <(settings <<<"$again") <(settings <<<"${third:-}") | head -10
    fail=1
  fi
  np=$((np + 1))
done
printed=$(check "$CONFIG/filter_recording.yaml" --print-config)
if ! grep -q '^  reorder_window_us: 500000$' <<<"$printed" || ! grep -q '^  gravity: 9.81  # default$' <<<"$printed"; then
  echo "FAIL: filter_recording.yaml's printed settings lack the file's reorder window or the marked default gravity"
  fail=1
fi
echo "$np printed settings read back"

# A user's copy with a misspelled key: refused, naming the file and the key.
for pair in "tracker.yaml tracker" "filter_recording.yaml filter" "e3d.yaml e3d" "sim_walk.yaml sim"; do
  set -- $pair
  cp "$CONFIG/$1" "$W/$1"
  printf '\nharris_treshold: 3\n' >>"$W/$1"
  if [ "$2" = sim ]; then
    sed -i "s|^base: *\(.*\)$|base: $CONFIG/\1|" "$W/$1"
    out=$("$BIN/sim" --scenario "$W/$1" --duration 0 --calib-out "$W/x.calib.yaml" 2>&1)
  else
    out=$("$BIN/$2" --check-config --config "$W/$1" "${head[@]}" 2>&1)
  fi
  rc=$?
  if [ $rc = 0 ] || ! grep -q "$W/$1: unknown key 'harris_treshold'" <<<"$out"; then
    echo "FAIL: $2 took a misspelled key (rc $rc): $out"
    fail=1
  fi
done
[ $fail = 0 ] && echo "PASS"
exit $fail
