#!/bin/bash
# The vertices codec (format v20, no grid) on the short clips against Draco
# and gltfpack, all frames: the peers, then `cgv eval --peers`, then each
# level's bits (ours interpolated log-log on the eval's points, the better
# peer's likewise). Sequences unpacked as .data/SEQ/SEQ (see README).
set -euo pipefail
cd "$(dirname "$0")/../../.."
out=${OUT:-out/short-clips}
mkdir -p "$out"
py=${PYTHON:-$HOME/.cache/cgv/venv/bin/python}
run() {
  s=$1; k=$2
  "$py" -m cgv.peers .data/$s/$s --surface-every 8 --node-modules tests/node/node_modules --json "$out/$s-peers.json"
  target/release/cgv eval .data/$s/$s --codecs vertices --kbps "$k" --surface-every 8 --peers "$out/$s-peers.json" \
      --json "$out/$s-vertices.json" --md "$out/$s-vertices.md"
}
run cylinder 90,110,140,180,230,280
run wolf 400,500,650,800,1000,1250,1500
run face-poses 1100,1600,2200,3000,3500,4000,4500
python3 docs/scripts/short-clips/levels.py "$out" cylinder wolf face-poses
