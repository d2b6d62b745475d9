#!/usr/bin/env bash
# The main job: set up what is missing, then turn the embedded default motion
# (a walking figure, 72 frames) into a seamless geometry-image sequence.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh

cargo build --release --bin cgv
cgv="$CARGO_TARGET_DIR/release/cgv"
mkdir -p out/demo
"$cgv" info builtin:walk
"$cgv" remesh builtin:walk -o out/demo/walk.glb --grid 128
echo
echo "Open out/demo/walk.glb in any glTF viewer (it plays as a morph-target animation);"
echo "out/demo/walk.png is its first geometry image (x, y, z as r, g, b)."
