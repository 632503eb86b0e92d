#!/usr/bin/env bash
# Builds build-asan/ with AddressSanitizer + UndefinedBehaviorSanitizer (CMake option
# SOCKETSMITH_SANITIZE) and runs the default test suite in it: every label but 'slow' and
# 'validation', as scripts/test.sh (the 'gui' tests start their own Xvfb), or the CTest arguments
# given instead, e.g. `scripts/sanitize.sh -R 'MeshIo|cli\.'`. docs/fuzzing.md has what it found.
#   SOCKETSMITH_SANITIZE_CMAKE_ARGS: more configure flags (e.g. -DSOCKETSMITH_BUILD_GUI=OFF)
#   SOCKETSMITH_JOBS: build and test jobs (default: all cores)
#   SOCKETSMITH_SANITIZE_TARGETS: build only these targets (e.g. "scan_tests calculix_tests"), not all
# Undefined behaviour stops the program that meets it (-fno-sanitize-recover), so a test cannot
# pass over it. ASan and UBSan exit 99 (their default, 1, is the CLI's "bad input", which the CLI tests
# expect; UBSan ignores ASan's exitcode). Leak checking is off (both unless ASAN_OPTIONS is set): this run is for memory errors
# and UB. UBSan stops at any report (halt_on_error=1, also for the one check built recoverable)
# except those scripts/ubsan.supp suppresses: UB inside third-party headers (CGAL), each entry with
# its reason. OpenMP is off: libgomp is not instrumented. The Python package is built
# too when pybind11 is found; python.pytest then runs the plain interpreter with the sanitizer
# runtimes preloaded (tests/CMakeLists.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SOCKETSMITH_BUILD_DIR:-build-asan}
JOBS=${SOCKETSMITH_JOBS:-$(nproc)}
LAUNCHER=()
if command -v ccache > /dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
# shellcheck disable=SC2086 # the extra flags are words
cmake -S . -B "$BUILD_DIR" -DSOCKETSMITH_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSOCKETSMITH_USE_OPENMP=OFF \
  -DSOCKETSMITH_BUILD_BENCHMARKS=OFF "${LAUNCHER[@]}" ${SOCKETSMITH_SANITIZE_CMAKE_ARGS:-} > "$BUILD_DIR.configure.log" 2>&1 \
  || { cat "$BUILD_DIR.configure.log"; exit 1; }
# shellcheck disable=SC2086 # the targets are words
cmake --build "$BUILD_DIR" -j"$JOBS" ${SOCKETSMITH_SANITIZE_TARGETS:+--target $SOCKETSMITH_SANITIZE_TARGETS}
SUPPRESSIONS="$PWD/scripts/ubsan.supp"
cd "$BUILD_DIR"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:exitcode=99}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:exitcode=99:suppressions=$SUPPRESSIONS}
if [ $# -eq 0 ]; then set -- -LE "slow|validation"; fi
ctest --output-on-failure -j"$JOBS" "$@"
