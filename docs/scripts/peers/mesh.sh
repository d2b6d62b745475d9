#!/usr/bin/env bash
# The input's mesh as today's encoder stores it, for each report of run.sh:
# `cgv encode` of the same frames and grid (QP 51: only the mesh's size is
# read), its `source_mesh_bytes` written to out/peers/SEQ-N.mesh.json, which
# summary.py uses instead of the report's own figure. The reports' motion
# bytes do not depend on how the mesh is stored (eval encodes the grid
# without it), so a change of the mesh's coding needs only this, not run.sh.
#
#   docs/scripts/peers/mesh.sh [NAME ...]     (default: all seven)
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV_BIN:-$HOME/.cache/cgv/target/release/cgv}
out=out/peers
declare -A frames=([samba]=0..60 [horse-gallop]=0..48 [pcow]=0..60 [horse-collapse]=0..53 [face-poses]=0..9 [cylinder]=0..4 [wolf]=0..6)
declare -A grids=([samba]="128 256" [horse-gallop]="128 256" [pcow]="128 256" [horse-collapse]="128" [face-poses]="128" [cylinder]="128" [wolf]="128")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for s in ${*:-samba horse-gallop pcow horse-collapse face-poses cylinder wolf}; do
  for n in ${grids[$s]}; do
    "$cgv" encode ".data/$s/$s" --frames "${frames[$s]}" --grid "$n" --qp 51 --json -o "$tmp/m.cgv" \
      | python3 -c "import json,sys; r=json.load(sys.stdin)['report']; print(json.dumps({'source_mesh_bytes': r['source_mesh_bytes']}))" \
      > "$out/$s-$n.mesh.json"
    echo "$s $n: $(cat "$out/$s-$n.mesh.json")"
  done
done
