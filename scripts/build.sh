#!/usr/bin/env bash
# Configures and builds socketsmith (Release, all cores) into ./build.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SOCKETSMITH_BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} > "$BUILD_DIR.configure.log" 2>&1 \
  || { cat "$BUILD_DIR.configure.log"; exit 1; }
cmake --build "$BUILD_DIR" -j"$(nproc)"
