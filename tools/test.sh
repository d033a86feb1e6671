#!/usr/bin/env bash
# Runs the whole test suite: installs what is missing (tools/setup.sh), builds in build/, runs ctest.
# Options: --no-setup (skip package installation), --sanitize (build in build-asan with clang, ASan+UBSan and run
# the unit tests there), extra arguments after -- go to ctest.
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
  # Clang: it compiles this build (CI's longest step) about a fifth faster than GCC (12 minutes against 15 on two
  # cores) with the same sanitizers, and a second compiler beside the release build's GCC shows what one compiler's
  # choices hide (the order in which a call's arguments are evaluated decided which random numbers a simulated
  # world drew).
  command -v clang++ >/dev/null || { echo "test.sh: clang++ not found (tools/setup.sh installs clang)" >&2; exit 1; }
  if [ -f $dir/CMakeCache.txt ] && ! grep -q "^CMAKE_CXX_COMPILER:.*clang" $dir/CMakeCache.txt; then
    rm -rf $dir  # configured with another compiler before: CMake keeps a cache's compiler
  fi
  # Line tables (-g1) are all a sanitizer's report needs, and they compile and link far faster than full debug info.
  # -O1, AddressSanitizer's recommended level: the instrumented build, CI's longest step, compiles about a third
  # faster than at -O2, and the unit tests run about as fast.
  CC=clang CXX=clang++ cmake -S . -B $dir -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DIPS_SANITIZE=ON >/dev/null
  # Only the unit tests' targets (and the libraries and tools they declare): the process mains, the other tools,
  # the benchmarks and the programs of slow tests serve the tests that run in build/ (tests/CMakeLists.txt).
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
