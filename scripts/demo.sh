#!/usr/bin/env bash
# The main job on the embedded sample: installs what is missing, builds, generates the project's
# sample transtibial limb (skin + tibia, fibula, patella, femur), meshes it into an ~8k-node
# MSS-CS stump and solves it under a uniform 3 kPa skin pressure, then runs the thesis's cube
# experiment (MSS-CS recommended constants, compared with MSS-CF and MSS in the plot).
#   out/sample/limb.stl, limb.json            the generated limb and its truth (frame, landmarks)
#   out/sample/mesh/{stump.vtu,limb.png,mesh.json,...}   the stump model (ParaView, picture, summary)
#   out/cube/{cube.csv,cube_all.csv,cube.svg,summary.json}
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
OUT=${1:-out}
build/socketsmith limb generate --type transtibial --seed 1 --out "$OUT/sample/limb.stl"
build/socketsmith mesh --limb "$OUT/sample/limb.stl" --target-nodes 8000 --load-kpa 3 --out "$OUT/sample/mesh"
build/socketsmith simulate cube --model mss-cs --out "$OUT/cube"
