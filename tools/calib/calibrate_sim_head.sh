#!/usr/bin/env bash
# The calibration chain of processes/calib/README.md ("Calibrating a new head") run on the simulated head, whose
# truth the simulator keeps: the head as designed, then the stereo cameras from a chart seen from 28 positions, the
# tilt sensor from eight static positions in front of it, and camera to IMU from the head waved for a minute with
# the tracker running (the main job's processes on the wave). Each tool updates one file, head.calib.yaml; at the
# end calib_compare says how far it is from the truth. Then
# `IPS_SCENARIO=config/sim_walk.yaml IPS_CALIB=OUT/head.calib.yaml ./tools/run.sh` runs the walk on it. Usage: tools/calib/calibrate_sim_head.sh [OUT_DIR] (default out/calib); IPS_SEED picks the head
# (default 1, the main job's).
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
BIN=$ROOT/build/bin
out=$(realpath -m "${1:-$ROOT/out/calib}")
seed=${IPS_SEED:-1}
mkdir -p "$out"
started=$(date +%s)
say() { printf '[calibration %4ds] %s\n' $(( $(date +%s) - started )) "$*"; }
last() { tail -n 1 "$1" | sed 's/^/    /'; }

say "0/3 the head as designed (nominal lenses and mounting) and its truth, seed $seed"
"$BIN/sim" --duration 0 --seed "$seed" --design-out "$out/design.calib.yaml" --calib-out "$out/truth.calib.yaml" \
  --log-level warn

say "1/3 stereo: the chart from 28 positions (config/sim_stereo_calib.yaml), calibrate_stereo"
"$BIN/sim" --scenario config/sim_stereo_calib.yaml --seed "$seed" --out "$out/stereo.lcmlog" --log-level warn
"$BIN/calibrate_stereo" --log "$out/stereo.lcmlog" --board 9x6 --square 0.1 --calib "$out/design.calib.yaml" \
  --out "$out/head.calib.yaml" --check-png "$out/rectified_check.png" > "$out/stereo.txt"
last "$out/stereo.txt"

say "2/3 tilt sensor: eight static positions in front of the chart (config/sim_tilt_calib.yaml), calibrate_tilt"
"$BIN/sim" --scenario config/sim_tilt_calib.yaml --seed "$seed" --out "$out/tilt.lcmlog" --log-level warn
"$BIN/calibrate_tilt" --log "$out/tilt.lcmlog" --calib "$out/head.calib.yaml" --board 9x6 --square 0.1 \
  --out "$out/head.calib.yaml" > "$out/tilt.txt"
last "$out/tilt.txt"

say "3/3 camera to IMU: the head waved (config/sim_imu_calib.yaml) through the main job's processes, calibrate_camera_imu"
IPS_CALIB="$out/head.calib.yaml" IPS_SCENARIO=config/sim_imu_calib.yaml IPS_SEED=$seed ./tools/main_job.sh \
  > "$out/wave_job.txt" 2>&1
wave=$(readlink -f out/latest)
"$BIN/calibrate_camera_imu" --log "$wave/results.lcmlog.00" --log "$wave/walk.lcmlog" --calib "$out/head.calib.yaml" \
  --out "$out/head.calib.yaml" > "$out/camera_imu.txt"
last "$out/camera_imu.txt"

say "against the truth (calib_compare; the truth file leaves out the tilt sensor's zero offsets, which the estimate takes up)"
"$BIN/calib_compare" --a "$out/truth.calib.yaml" --b "$out/head.calib.yaml" | tee "$out/compare.txt" | sed 's/^/    /'
say "done: $out/head.calib.yaml (IPS_SCENARIO=config/sim_walk.yaml IPS_CALIB=$out/head.calib.yaml ./tools/run.sh runs the walk on it)"
