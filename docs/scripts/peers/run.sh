#!/usr/bin/env bash
# Draco per frame and gltfpack morph targets beside our codec, on the same
# frames with the same surface distance (RESULTS, "Against what users ship").
# For each sequence: python -m cgv.peers, then cgv eval --codecs predictive at
# N = 128 and 256 with the peers joined, then summary.py over all of them.
# Our rate points are bits per input vertex per frame (motion only; the
# report adds the input's mesh for the comparison).
# Needs the sequences unpacked as .data/NAME/NAME, the Python package with
# DracoPy in ~/.cache/cgv/venv and tests/node's gltfpack (pkg-scripts/setup.sh).
#
#   docs/scripts/peers/run.sh [NAME ...]     (default: all seven)
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV_BIN:-$HOME/.cache/cgv/target/release/cgv}
py=${CGV_VENV:-$HOME/.cache/cgv/venv}/bin/python
out=out/peers
export CGV_NODE_MODULES=${CGV_NODE_MODULES:-$PWD/tests/node/node_modules}
mkdir -p "$out"
# name, frames, grid sizes
declare -A frames=([samba]=0..60 [horse-gallop]=0..48 [pcow]=0..60 [horse-collapse]=0..53 [face-poses]=0..9 [cylinder]=0..4 [wolf]=0..6)
declare -A grids=([samba]="128 256" [horse-gallop]="128 256" [pcow]="128 256" [horse-collapse]="128" [face-poses]="128" [cylinder]="128" [wolf]="128")
# bits per input vertex per frame: few vertices (cylinder's 420 against the
# grid's 16 384 samples) or few frames (wolf's 6) cost more per vertex.
declare -A bpvf=([cylinder]="15 30 60 120 240" [wolf]="1 2.5 6 15 40")
for s in ${*:-samba horse-gallop pcow horse-collapse face-poses cylinder wolf}; do
  input=.data/$s/$s
  [ -e "$out/$s-peers.json" ] || "$py" -m cgv.peers "$input" --frames "${frames[$s]}" --json "$out/$s-peers.json"
  v=$("$py" -c "import json; print(json.load(open('$out/$s-peers.json'))['input_vertices'])")
  rates=${bpvf[$s]:-0.4 1 2.5 6 15}
  kbps=$("$py" -c "print(','.join(f'{float(b) * $v * 30 / 1000:.1f}' for b in '$rates'.split()))")
  for n in ${grids[$s]}; do
    [ -e "$out/$s-$n.json" ] || "$cgv" eval "$input" --frames "${frames[$s]}" --grid "$n" --codecs predictive --kbps "$kbps" \
      --peers "$out/$s-peers.json" --json "$out/$s-$n.json" --md "$out/$s-$n.md" --plot "$out/$s-$n.svg"
  done
done
"$py" docs/scripts/peers/summary.py "$out"/*-1[0-9][0-9].json "$out"/*-2[0-9][0-9].json
