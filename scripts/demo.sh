#!/usr/bin/env bash
# The main job on the embedded sample: installs what is missing, builds, and runs
# `socketsmith demo`: the project's generated transtibial limb (skin + tibia, fibula, patella,
# femur) → an ~8k-node stump (neo-Hookean tissue, solved nonlinearly) → the default pressure-spot
# layout optimised until the seven radar constraints hold for a 70 kg patient (E = 100 kPa, ν 0.45,
# μ = 0.5) → the socket (5 mm wall, PTB brim, distal pad) and its report. Then the thesis's cube
# experiment.
#   out/demo/case.json            the case (edit it and replay: build/socketsmith design out/demo/case.json --out DIR)
#   out/demo/socket.stl           the socket, mm, ready to print
#   out/demo/report.html          patient, radar, pressure maps, profiles, socket measurements
#   out/demo/{surface_nodes.csv,stump.vtu,radar.png,pressure_map.png,ratio_map.png,design.json,design_case.json}
#   out/cube/{cube.csv,cube_all.csv,cube.svg,summary.json}
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
OUT=${1:-out}
build/socketsmith demo --out "$OUT/demo"
build/socketsmith simulate cube --model mss-cs --out "$OUT/cube"
