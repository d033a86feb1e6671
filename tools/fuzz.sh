#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang, AddressSanitizer and UBSan in build-fuzz/ and runs each
# from its committed seed corpus with a fixed seed (repeatable). Option: --runs N inputs per target (default
# 20000, as in CI; 1000000 is the documented long run).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=20000
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=$2; shift ;;
    *) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (tools/setup.sh installs clang)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIPS_FUZZ=ON -DIPS_SANITIZE=ON \
  -DIPS_FUZZ_RUNS="$runs" >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_all
(cd build-fuzz && ctest -j"$(nproc)" -L fuzz --output-on-failure --timeout 3600)
