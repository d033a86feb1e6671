#!/usr/bin/env bash
# dataset_to_lcm on bad folders: one line naming the file (and line), exit code 1, and no output left behind,
# also when the fault shows only while writing (an image of another size halfway through).
set -uo pipefail
BIN=$1 DATA=$(realpath -m "$2")
MH=$DATA/euroc/MH_01_easy_first150
KITTI_IMAGE=$DATA/kitti_odometry/06_first51/sequences/06/image_0/000000.png
[ -d "$MH" ] && [ -f "$KITTI_IMAGE" ] || { echo "SKIP: shared data missing (see ../shared/data)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
scratch() {  # an EuRoC folder of the first 5 frames, images linked
  local d=$work/$1
  for cam in cam0 cam1; do
    mkdir -p "$d/mav0/$cam/data"
    cp "$MH/mav0/$cam/sensor.yaml" "$d/mav0/$cam/"
    head -6 "$MH/mav0/$cam/data.csv" > "$d/mav0/$cam/data.csv"
    tail -n +2 "$d/mav0/$cam/data.csv" | cut -d, -f2 | tr -d '\r' | while read -r f; do
      ln -s "$MH/mav0/$cam/data/$f" "$d/mav0/$cam/data/$f"; done
  done
  echo "$d"
}
expect_error() {  # folder, text the one-line error must hold
  local out=$work/out.lcmlog
  "$BIN/dataset_to_lcm" --format euroc --in "$1" --out "$out" 2> "$work/err"
  local rc=$?
  cat "$work/err"
  [ "$rc" = 1 ] || fail "exit code $rc, expected 1"
  [ "$(wc -l < "$work/err")" = 1 ] || fail "error is not one line"
  grep -q -- "$2" "$work/err" || fail "error does not name '$2'"
  [ -z "$(ls "$work" | grep out.lcmlog)" ] || fail "output left behind: $(ls "$work" | grep out.lcmlog)"
}
d=$(scratch good)
"$BIN/dataset_to_lcm" --format euroc --in "$d" --out "$work/good.lcmlog" | grep -q "5 stereo pairs" || fail "good folder"
rm -f "$work"/good.lcmlog*

d=$(scratch badline); sed -i '3s/,/;/' "$d/mav0/cam0/data.csv"
expect_error "$d" "cam0/data.csv:3:"
d=$(scratch order); sed -i '4s/^1403636584/1403636583/' "$d/mav0/cam1/data.csv"
expect_error "$d" "cam1/data.csv:4: time stamp"
d=$(scratch size); f=$(sed -n 5p "$d/mav0/cam1/data.csv" | cut -d, -f2 | tr -d '\r')
ln -sf "$KITTI_IMAGE" "$d/mav0/cam1/data/$f"
expect_error "$d" "cam1/data/$f: image is 1226x370"
echo PASS
