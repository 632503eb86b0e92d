#!/usr/bin/env bash
# Regenerates the GUI screenshots of docs/gui.md (docs/images/gui_*.png) with the headless mode of
# socketsmith-gui under Xvfb: the demo stump (8k nodes), a spot added at the patellar tendon,
# the optimiser, the displacement with the socket, what the socket delivers (the closed loop, about a
# minute at 8k), the threshold map with a KBM brim.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/socketsmith-gui ] || { echo "gui_screenshots: build socketsmith-gui first (scripts/build.sh)"; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/script.json" <<'JSON'
{"actions": [
  {"do": "view", "yaw_deg": 35, "pitch_deg": 12},
  {"do": "screenshot", "name": "gui_main.png"},
  {"do": "add_spot", "landmark": "PT", "type": "cos2", "amplitude_kpa": 60},
  {"do": "select_spot", "spot": "PT (added)"},
  {"do": "field", "value": "pressure"},
  {"do": "screenshot", "name": "gui_spot_added.png"},
  {"do": "optimise"},
  {"do": "field", "value": "ratio"},
  {"do": "screenshot", "name": "gui_optimised_ratio.png"},
  {"do": "field", "value": "displacement"},
  {"do": "view", "yaw_deg": 150, "pitch_deg": 10, "bones": false, "socket": true},
  {"do": "screenshot", "name": "gui_displacement.png"},
  {"do": "field", "value": "delivered"},
  {"do": "view", "yaw_deg": 35, "pitch_deg": 12, "bones": false, "socket": false},
  {"do": "screenshot", "name": "gui_delivered.png"},
  {"do": "brim", "template": "kbm"},
  {"do": "field", "value": "threshold"},
  {"do": "view", "yaw_deg": 60, "pitch_deg": 15, "bones": true, "socket": false, "stump_opacity": 0.55},
  {"do": "screenshot", "name": "gui_threshold_kbm.png"}
]}
JSON
xvfb-run -a -s "-noreset -screen 0 1600x1000x24" build/socketsmith-gui --headless --demo --target-nodes 8000 \
  --script "$tmp/script.json" --frames 1 --screenshot-dir "$tmp"
mkdir -p docs/images
cp "$tmp"/gui_*.png docs/images/
ls -l docs/images/gui_*.png
