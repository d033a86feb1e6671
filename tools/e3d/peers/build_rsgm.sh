#!/bin/sh
# Builds the rSGM harness (rsgm_match.cpp) against a checkout of kbatsos/Real-Time-Stereo kept outside the project.
#   tools/e3d/peers/build_rsgm.sh RSGM_CHECKOUT OUT_BINARY
# rSGM's sources use AVX2 intrinsics without including immintrin.h, hence -include.
set -eu
if [ $# -ne 2 ]; then
  echo "usage: $0 RSGM_CHECKOUT OUT_BINARY" >&2
  exit 2
fi
src="$1/CPU/sgm"
here=$(dirname "$0")
g++ -O3 -march=native -fopenmp -include immintrin.h -w "$here/rsgm_match.cpp" "$src"/*.cpp -I"$src" \
  $(pkg-config --cflags --libs opencv4) -o "$2"
