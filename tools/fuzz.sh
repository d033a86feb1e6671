#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang, AddressSanitizer and UBSan in build-fuzz/, and runs
# each from its committed seed corpus. Options: --seconds N (per target, default 10), --runs N (a number of
# inputs per target instead of a time, e.g. 1000000 for the documented long run).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=10; runs=0
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift ;;
    --runs) runs=$2; shift ;;
    *) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (tools/setup.sh installs clang)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIPS_FUZZ=ON -DIPS_SANITIZE=ON \
  -DIPS_FUZZ_SECONDS="$seconds" >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_all
if [ "$runs" -gt 0 ]; then
  for bin in build-fuzz/bin/fuzz_*; do
    name=$(basename "$bin")
    seeds=tests/fuzz/corpus/$name
    work=build-fuzz/tests/fuzz/corpus/$name
    echo "fuzz.sh: $name, $runs inputs"
    "$bin" -runs="$runs" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 "$work" "$seeds" 2>&1 |
      grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|ERROR|SUMMARY|Done" || true
    [ "${PIPESTATUS[0]}" -eq 0 ] || { echo "fuzz.sh: $name found a failure (input saved in the working folder)" >&2; exit 1; }
  done
else
  (cd build-fuzz && ctest -j"$(nproc)" -L fuzz --output-on-failure)
fi
