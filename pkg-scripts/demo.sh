#!/usr/bin/env bash
# The main job: set up what is missing, build the CLI and the web viewer,
# turn the embedded default motion (a walking figure, 72 frames) into a
# geometry-image sequence and into .cgv files (the project's CGV and the GV
# baseline), draw one frame, and serve the viewer with both, side by side.
# CGV_DEMO_NO_SERVE=1 stops before serving; PORT picks the port (8080).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source pkg-scripts/setup.sh

cargo build --release --bin cgv
bash pkg-scripts/web.sh
cgv="$CARGO_TARGET_DIR/release/cgv"
mkdir -p out/demo www/media
"$cgv" info builtin:walk --quick
"$cgv" remesh builtin:walk -o out/demo/walk.glb --grid 128
# The viewer draws the grid mesh, so the files leave out the figure's own
# mesh (--no-source-mesh: it would add 110 KB to each; `cgv decode` of a
# file that carries it gives back the input's vertices and faces).
"$cgv" encode builtin:walk -o www/media/walk.cgv --codec auto --grid 128 --qp 30 --no-source-mesh
# GV at the CGV file's bitrate (--kbps keeps it within 5 %).
cgv_kbps=$(awk -v b="$(stat -c %s www/media/walk.cgv)" 'BEGIN { printf "%.0f", b * 8 / 1000 / 2.4 }')
"$cgv" encode builtin:walk -o www/media/walk-gv.cgv --codec gv --grid 128 --kbps "$cgv_kbps" --no-source-mesh
"$cgv" render www/media/walk.cgv --frame 36 -o out/demo/walk-36.png
# The two files' real sizes (2.4 s of motion each).
kb() { awk -v b="$(stat -c %s "$1")" 'BEGIN { printf "%.1f KB, %.0f kbit/s", b / 1000, b * 8 / 1000 / 2.4 }'; }
sizes="left: the project's CGV (QP 30), $(kb www/media/walk.cgv); right: GV (--kbps $cgv_kbps), $(kb www/media/walk-gv.cgv)"
echo
echo "out/demo/walk.glb plays in any glTF viewer; out/demo/walk-36.png is frame 36 as cgv draws it."
echo "$sizes"
port="${PORT:-8080}"
if [ "${CGV_DEMO_NO_SERVE:-0}" = 1 ]; then
  echo "viewer: $cgv serve www --port $port, then open http://127.0.0.1:$port/?src=media/walk.cgv&compare=media/walk-gv.cgv&autoplay"
  exit 0
fi
echo "Open http://127.0.0.1:$port/?src=media/walk.cgv&compare=media/walk-gv.cgv&autoplay"
echo "($sizes; Ctrl-C stops the server)"
exec "$cgv" serve www --port "$port"
