#!/usr/bin/env bash
# Installs what is missing, builds, and runs the default test suite (everything but 'slow',
# 'gui' and 'validation' labels unless SOCKETSMITH_TEST_LABELS overrides the selection).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
cd build
ctest --output-on-failure -j"$(nproc)" ${SOCKETSMITH_TEST_ARGS:--LE "slow|gui|validation"}
