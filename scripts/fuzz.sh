#!/usr/bin/env bash
# scripts/fuzz.sh [SECONDS] [TARGET...]: builds the libFuzzer targets (clang 14, ASan + UBSan,
# SOCKETSMITH_FUZZ=ON) into build-fuzz/ and runs each for SECONDS (default 60) from its seed corpus
# tests/fuzz/corpus/<target>/. Targets: stl obj ply limb case_file design (default: all; limb: a limb
# file of any format made into a limb model and meshed at 300 nodes, as `socketsmith mesh` does).
# Prints, per target, the executions, the inputs in the grown corpus and the failures; a failing
# input is saved as build-fuzz/findings/<target>/crash-* (or timeout-*, oom-*): copy it into
# tests/fuzz/corpus/<target>/ with the fix, so fuzz_regression_tests replays it in every test run.
# Exit status: 0 when no target failed, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(stl obj ply limb case_file design)

# The build packages, and clang with its sanitizer/libFuzzer runtime (Debian 12: clang 14).
scripts/setup.sh --dev > /dev/null

BUILD=${SOCKETSMITH_FUZZ_BUILD_DIR:-build-fuzz}
LAUNCHER=()
if command -v ccache > /dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
mkdir -p "$BUILD"
CXX=clang++ CC=clang cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSOCKETSMITH_FUZZ=ON \
  -DSOCKETSMITH_BUILD_TESTS=OFF -DSOCKETSMITH_BUILD_BENCHMARKS=OFF -DSOCKETSMITH_BUILD_GUI=OFF \
  -DSOCKETSMITH_USE_OPENMP=OFF "${LAUNCHER[@]}" > "$BUILD.configure.log" 2>&1 || { cat "$BUILD.configure.log"; exit 1; }
cmake --build "$BUILD" -j"$(nproc)" --target $(printf 'fuzz_%s ' "${targets[@]}")

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
status=0
printf '%-10s %12s %8s %8s\n' target executions corpus failures
for t in "${targets[@]}"; do
  corpus="$BUILD/corpus/$t"; findings="$BUILD/findings/$t"
  mkdir -p "$corpus" "$findings"
  # Each run: -rss_limit_mb guards against inputs that ask for huge allocations, -timeout flags
  # inputs that hang (the design target runs the optimiser with a 1 s time limit).
  timeout_s=10; [ "$t" = design ] && timeout_s=30; [ "$t" = limb ] && timeout_s=30
  dict=tests/fuzz/mesh.dict; case "$t" in case_file|design) dict=tests/fuzz/case_file.dict ;; esac
  log="$BUILD/findings/$t.log"
  set +e
  "$BUILD/tests/fuzz/fuzz_$t" "$corpus" "tests/fuzz/corpus/$t" -max_total_time="$seconds" -timeout="$timeout_s" \
    -rss_limit_mb=2048 -max_len=65536 -dict="$dict" -print_final_stats=1 -artifact_prefix="$findings/" -fork=0 > "$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  failures=$(find "$findings" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'timeout-*' -o -name 'oom-*' -o -name 'leak-*' \) | wc -l)
  printf '%-10s %12s %8s %8s\n' "$t" "${execs:-?}" "$(find "$corpus" -type f | wc -l)" "$failures"
  if [ "$rc" != 0 ] || [ "$failures" != 0 ]; then
    status=1
    echo "fuzz: $t failed (exit $rc); the input is in $findings, the report in $log:"
    grep -m 5 -E 'ERROR|runtime error|terminate|what\(\)' "$log" || tail -5 "$log"
  fi
done
exit $status
