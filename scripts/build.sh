#!/usr/bin/env bash
# Configures and builds socketsmith (Release, all cores) into ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SOCKETSMITH_BUILD_DIR:-build}
# ccache, when installed, makes rebuilds (and builds of other clones under the same base_dir) fast.
LAUNCHER=()
if command -v ccache > /dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} "${LAUNCHER[@]}" > "$BUILD_DIR.configure.log" 2>&1 \
  || { cat "$BUILD_DIR.configure.log"; exit 1; }
cmake --build "$BUILD_DIR" -j"$(nproc)"
