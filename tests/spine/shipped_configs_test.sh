#!/usr/bin/env bash
# Every configuration file the project ships, read by the process that reads it (--check-config): each of its keys
# must be a setting of that process, so a stale or misspelled key in a shipped file cannot sit there doing nothing.
# And a misspelled key in a user's copy is refused, naming the file and the key.
#   shipped_configs_test.sh BIN_DIR CONFIG_DIR
set -uo pipefail
BIN=$1
CONFIG=$2
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
"$BIN/sim" --duration 0 --calib-out "$W/head.calib.yaml" --log-level error || { echo "FAIL: no calibration"; exit 1; }
head=(--calib "$W/head.calib.yaml")
fail=0
# process FILE: checks FILE with the process that reads it; prints the process's answer
check() {
  local file=$1 name
  name=$(basename "$file")
  case $name in
    tracker.yaml | euroc.yaml | kitti.yaml) "$BIN/tracker" --check-config --config "$file" "${head[@]}" ;;
    filter*.yaml) "$BIN/filter" --check-config --config "$file" "${head[@]}" ;;
    e3d*.yaml) "$BIN/e3d" --check-config --config "$file" "${head[@]}" ;;
    mapper*.yaml) "$BIN/mapper" --check-config --config "$file" "${head[@]}" ;;
    viewer*.yaml) "$BIN/viewer" --check-config --config "$file" ;;
    camera*.yaml) "$BIN/camera" --check-config --config "$file" ;;
    imu*.yaml) "$BIN/imu" --check-config --config "$file" ;;
    tilt*.yaml) "$BIN/tilt" --check-config --config "$file" ;;
    sim_*.yaml) "$BIN/sim" --scenario "$file" --duration 0 --calib-out "$W/scenario.calib.yaml" --log-level error &&
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
