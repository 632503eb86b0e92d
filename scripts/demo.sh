#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the thesis's cube experiment
# (MSS-CS with the recommended constants, compared with MSS-CF and MSS in the plot),
# writing out/cube/{cube.csv,cube_all.csv,cube.svg,summary.json}.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
OUT=${1:-out/cube}
build/socketsmith simulate cube --model mss-cs --out "$OUT"
