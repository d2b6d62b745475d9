#!/usr/bin/env bash
# --target-error on samba at N = 128: each target's file, the QP it kept,
# its size, the encoder's own figure (12 frames), and the surface RMS over
# every frame measured independently from the decoded grid (check.py, the
# Python package). Needs samba unpacked as .data/samba/samba and the
# package installed (pkg-scripts/test.sh installs it into ~/.cache/cgv/venv).
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=./target/release/cgv
out=out/target-error
mkdir -p "$out"
for t in ${*:-0.1 0.05 0.03}; do
  "$cgv" encode .data/samba/samba --grid 128 --target-error "$t" -o "$out/samba-$t.cgv" --json > "$out/samba-$t.json"
  ~/.cache/cgv/venv/bin/python docs/scripts/target-error/check.py .data/samba/samba "$out/samba-$t.cgv" "$out/samba-$t.json" "$t"
done
