#!/usr/bin/env bash
# The normal codec (format v9) against the predictive one: `cgv eval` of
# the closed-loop corrections as x, y, z at full size (predictive; files
# named -world) and as x, y, z halved plus dn (normal), on the shared
# sequences, then `cgv bdrate` between the two.
# Usage: docs/scripts/normal-correction/run.sh [GRID] [SEQUENCE...]
set -euo pipefail
cd "$(dirname "$0")/../../.."
grid=${1:-128}
shift || true
seqs=${*:-samba horse-gallop pcow}
out=out/normal/$grid
mkdir -p "$out"
cgv=./target/release/cgv
for s in $seqs; do
  dir=.data/$s/$s
  for layout in world normal; do
    codec=normal; [ "$layout" = world ] && codec=predictive
    [ -f "$out/$s-$layout.json" ] && continue
    /usr/bin/time -f "$s $layout: %e s, %M KB" \
      "$cgv" eval "$dir" --grid "$grid" --codecs "$codec" --surface-every 2 \
      --json "$out/$s-$layout.json" > "$out/$s-$layout.log" 2>&1
    tail -1 "$out/$s-$layout.log"
  done
  "$cgv" bdrate "$out/$s-world.json" "$out/$s-normal.json" --codec normal --reference-codec predictive | tee "$out/$s-bdrate.txt"
done
