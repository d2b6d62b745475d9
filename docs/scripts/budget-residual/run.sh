#!/bin/bash
# The budget's vertex residual try in docs/RESULTS.md ("On budget"): each
# sequence encoded with `cgv encode --kbps K` (auto codec and grid), the
# try's line from the report, then the kept file decoded to OBJ and measured
# on the input's own vertices over all frames. Appends one row per budget to
# budget-residual.tsv: sequence, kbit/s, bytes, bits/v/f, vertex RMS %,
# worst frame %, and the report's try.
# Usage: bash docs/scripts/budget-residual/run.sh .data   (sequences unpacked there)
set -euo pipefail
data=${1:-.data}
cgv=${CGV:-target/release/cgv}
here=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-budget-residual.tsv}
run() {  # SEQ KBPS...
  local seq=$1; shift
  local frames; frames=$(ls "$data/$seq/$seq"/*.obj | wc -l)
  for k in "$@"; do
    local f; f=$(mktemp -d)
    "$cgv" encode "$data/$seq/$seq" --kbps "$k" -o "$f/x.cgv" > "$f/log"
    mkdir "$f/out"
    "$cgv" decode "$f/x.cgv" -o "$f/out/" > /dev/null
    local tried; tried=$(grep "tried under the budget" "$f/log" | sed 's/^ *//' || echo "no residual tried")
    python3 "$here/../vertex-residual/vertex_error.py" "$data/$seq/$seq" "$f/out" "$frames" "$(stat -c %s "$f/x.cgv")" \
      | sed "s/^/$seq\t$k\t/; s/$/\t$tried/" >> "$out"
    rm -rf "$f"
  done
}
run pcow 600 1000 1500
run horse-collapse 900 1500
run samba 1000 1800
run horse-gallop 1000 1800
