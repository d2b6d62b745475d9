#!/bin/bash
# The vertex residual's table in docs/RESULTS.md ("The vertex residual"):
# each sequence encoded with a residual of P % at a fixed video QP, decoded to
# OBJ, and measured on the input's own vertices (all frames). Appends one row
# per file to vertex-residual.tsv: sequence, codec, QP, P, bytes, bits per
# vertex per frame (whole file), vertex RMS % and worst frame %.
# Usage: bash docs/scripts/vertex-residual/run.sh .data   (sequences unpacked there)
set -euo pipefail
data=${1:-.data}
cgv=${CGV:-target/release/cgv}
here=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-vertex-residual.tsv}
run() {  # SEQ CODEC QP P...
  local seq=$1 codec=$2 qp=$3; shift 3
  local frames; frames=$(ls "$data/$seq/$seq"/*.obj | wc -l)
  for p in "$@"; do
    local f; f=$(mktemp -d)
    "$cgv" encode "$data/$seq/$seq" --codec "$codec" --qp "$qp" --vertex-residual "$p" -o "$f/x.cgv" > /dev/null
    mkdir "$f/out"
    "$cgv" decode "$f/x.cgv" -o "$f/out/" > /dev/null
    python3 "$here/vertex_error.py" "$data/$seq/$seq" "$f/out" "$frames" "$(stat -c %s "$f/x.cgv")" \
      | sed "s/^/$seq\t$codec\t$qp\t$p\t/" >> "$out"
    rm -rf "$f"
  done
}
run pcow skinned 45 0.2 0.1 0.07 0.05 0.035
run horse-collapse skinned 45 0.2 0.1 0.07 0.05 0.035
run horse-gallop skinned 45 0.1 0.05 0.035
run samba skinned 45 0.1 0.05 0.035
run face-poses normal 20 0.2 0.1 0.05
run face-poses skinned 45 0.2 0.1
run cylinder normal 20 0.2 0.1 0.05
