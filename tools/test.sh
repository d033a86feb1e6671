#!/usr/bin/env bash
# Runs the whole test suite: installs what is missing (tools/setup.sh), builds in build/, runs ctest.
# Options: --no-setup (skip package installation), --sanitize (build in build-asan with ASan+UBSan and run the
# unit tests there), extra arguments after -- go to ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
setup=1; sanitize=0; ctest_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --no-setup) setup=0 ;;
    --sanitize) sanitize=1 ;;
    --) shift; ctest_args=("$@"); break ;;
    *) echo "test.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[ $setup = 1 ] && ./tools/setup.sh
jobs=$(nproc)
if [ $sanitize = 1 ]; then
  dir=build-asan
  # Line tables (-g1) are all a sanitizer's report needs, and they compile and link far faster than full debug info.
  # -O1, AddressSanitizer's recommended level: the instrumented build, CI's longest step, compiles about a third
  # faster than at -O2, and the unit tests run about as fast.
  cmake -S . -B $dir -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
    -DIPS_SANITIZE=ON >/dev/null
  # Only the tests' targets (and the libraries and tools they declare): the process mains, the other tools and
  # the benchmarks serve the process tests, which run in build/.
  make -C $dir/tests -j"$jobs"
  # Unit tests under the sanitizers; tests of whole processes, system tests and the longest unit tests are labelled
  # (process, slow) and run in build/.
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1
  (cd $dir && ctest -j"$jobs" --output-on-failure --timeout 900 -LE "process|slow" "${ctest_args[@]}")
else
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build build -j"$jobs"
  (cd build && ctest -j"$jobs" --output-on-failure --timeout 900 "${ctest_args[@]}")
fi
