#!/usr/bin/env bash
# Bad configuration and calibration files into the real processes: each must stop at once with an error that
# names the file (and the key where there is one), never hang in a parser, never crash, never start on NaN.
set -euo pipefail
BIN=$1; SRC=$2; DATA=$3; W=${4:-$(mktemp -d)}
mkdir -p "$W"
U="udpm://239.255.76.67:7725?ttl=0"
# A calibration the processes accept, written by the simulator for its head.
"$BIN/sim" --duration 0.5 --out "$W/walk.lcmlog" --seed 1 --log-level warn > /dev/null
CALIB="$W/walk.lcmlog.calib.yaml"
fail=0

# expect_refused NAME EXPECTED_TEXT COMMAND...: exits non-zero within 30 s, without a signal, saying EXPECTED_TEXT
expect_refused() {
  local name=$1 text=$2; shift 2
  set +e
  timeout 30 "$@" > "$W/$name.out" 2>&1
  local rc=$?
  set -e
  if [ $rc -eq 0 ]; then
    echo "FAIL: $name: accepted"; fail=1
  elif [ $rc -eq 124 ]; then
    echo "FAIL: $name: still running after 30 s (hangs)"; fail=1
  elif [ $rc -gt 128 ]; then
    echo "FAIL: $name: killed by signal $((rc - 128))"; fail=1
  elif ! grep -qF -- "$text" "$W/$name.out"; then
    echo "FAIL: $name: the error does not say '$text':"; cat "$W/$name.out"; fail=1
  else
    echo "ok: $name: $(grep -F -- "$text" "$W/$name.out" | head -1)"
  fi
}

yaml() { printf '%%YAML:1.0\n%s\n' "$2" > "$W/$1.yaml"; echo "$W/$1.yaml"; }

# A 21-byte file that made OpenCV's parser spin forever.
printf '%%YAML:1.0\n{ a: [ b: \n' > "$W/malformed.yaml"
expect_refused tracker_malformed "malformed.yaml" "$BIN/tracker" --lcm-url "$U" --calib "$CALIB" --config "$W/malformed.yaml"
expect_refused filter_malformed "malformed.yaml" "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$W/malformed.yaml"
expect_refused e3d_malformed "malformed.yaml" "$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$W/malformed.yaml"
expect_refused calib_malformed "malformed.yaml" "$BIN/tracker" --lcm-url "$U" --calib "$W/malformed.yaml" \
  --config "$SRC/config/tracker.yaml"

f=$(yaml heading_nan "filter:
  init:
    heading_rad: .nan")
expect_refused filter_heading_nan "init/heading_rad" "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$f"
f=$(yaml gravity_inf "filter:
  gravity: .inf")
expect_refused filter_gravity_inf "gravity" "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$f"
f=$(yaml imu_gap_huge "filter:
  imu_gap_s: 1.0e+300")
expect_refused filter_imu_gap_huge "imu_gap_s" "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$f"
f=$(yaml ukf_beta_nan "filter:
  ukf:
    beta: .nan")
expect_refused filter_ukf_beta_nan "ukf/beta" "$BIN/filter" --lcm-url "$U" --calib "$CALIB" --config "$f"

f=$(yaml max_queue_negative "process:
  max_queue: -1")
expect_refused e3d_max_queue_negative "process/max_queue" "$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$f"
f=$(yaml max_queue_zero "process:
  queue_all: 1
  max_queue: 0")
expect_refused e3d_max_queue_zero "process/max_queue" "$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$f"
f=$(yaml every_nth_zero "process:
  every_nth: 0")
expect_refused e3d_every_nth_zero "process/every_nth" "$BIN/e3d" --lcm-url "$U" --calib "$CALIB" --config "$f"

# NaN in a camera matrix: no process may rectify or triangulate with it.
python3 - "$CALIB" "$W/calib_nan.yaml" <<'EOF'
import re, sys
text = open(sys.argv[1]).read()
# the first number of cam0's K (the focal length) becomes .nan
text = re.sub(r"(K: !!opencv-matrix\s+rows: 3\s+cols: 3\s+dt: d\s+data: \[ )[-0-9.e+]+", r"\g<1>.nan", text, count=1)
open(sys.argv[2], "w").write(text)
EOF
grep -q "data: \[ .nan" "$W/calib_nan.yaml" || { echo "FAIL: could not write the NaN calibration"; exit 1; }
expect_refused e3d_calib_nan "calib_nan.yaml" "$BIN/e3d" --lcm-url "$U" --calib "$W/calib_nan.yaml" --config "$SRC/config/e3d.yaml"
expect_refused tracker_calib_nan "calib_nan.yaml" "$BIN/tracker" --lcm-url "$U" --calib "$W/calib_nan.yaml" \
  --config "$SRC/config/tracker.yaml"
expect_refused filter_calib_nan "calib_nan.yaml" "$BIN/filter" --lcm-url "$U" --calib "$W/calib_nan.yaml" \
  --config "$SRC/config/filter_sim.yaml"

# Bad files into the tools: an output path that cannot be written is an error, not exit 0 without the file.
expect_refused e3d_match_unwritable_png "cannot write /nonexistent/x.png" "$BIN/e3d_match" \
  --left "$DATA/stereo/venus/left.png" --right "$DATA/stereo/venus/right.png" --out "$W/venus.pfm" \
  --out-png /nonexistent/x.png
# Files and arguments that once got an unhelpful word or none (the probe of crafted inputs): each now names what is
# wrong, and where.
expect_refused tracker_calib_missing "/nonexistent/head.calib.yaml: cannot open" "$BIN/tracker" --lcm-url "$U" \
  --calib /nonexistent/head.calib.yaml --config "$SRC/config/tracker.yaml"
: > "$W/empty.yaml"
expect_refused tracker_config_empty "empty.yaml: holds no keys" "$BIN/tracker" --lcm-url "$U" --calib "$CALIB" \
  --config "$W/empty.yaml"
sed '0,/^   width: .*/s//   width: 2000000000/' "$CALIB" > "$W/calib_wide.yaml"
expect_refused tracker_calib_width "calib_wide.yaml: key 'cam0/width|height' must be in 1..16384" "$BIN/tracker" \
  --lcm-url "$U" --calib "$W/calib_wide.yaml" --config "$SRC/config/tracker.yaml"
mkdir -p "$W/euroc/mav0/cam0" "$W/euroc/mav0/cam1"
printf '#timestamp [ns],filename\n1403636579763555584,1403636579763555584.png\n14036365798x,b.png\n' \
  > "$W/euroc/mav0/cam0/data.csv"
expect_refused stereo_player_bad_csv "cam0/data.csv:3: expected 'timestamp_ns,filename'" "$BIN/stereo_player" \
  --lcm-url "$U" --euroc "$W/euroc/mav0"
expect_refused stereo_player_rate "--rate must be in [0.01, 1000] Hz" "$BIN/stereo_player" --lcm-url "$U" \
  --left "$DATA/stereo/venus/left.png" --right "$DATA/stereo/venus/right.png" --rate 1e-300
expect_refused e3d_match_range "has no match in an image" "$BIN/e3d_match" --left "$DATA/stereo/venus/left.png" \
  --right "$DATA/stereo/venus/right.png" --out "$W/venus_range.pfm" --min-disparity 4000
expect_refused ips_report_pictures "--pictures must not be negative" "$BIN/ips_report" --log "$W/walk.lcmlog" \
  --out "$W/report_pictures" --pictures -3

[ $fail -eq 0 ] && echo "PASS: every bad file refused with its name"
exit $fail
