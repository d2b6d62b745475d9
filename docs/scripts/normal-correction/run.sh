#!/usr/bin/env bash
# The normal correction (format v9) against today's codec: `cgv eval` of
# the project's codec with x, y, z at full size and with x, y, z halved plus
# dn, on the shared sequences, then `cgv bdrate` between the two.
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
    flag=(); [ "$layout" = normal ] && flag=(--normal-correction)
    [ -f "$out/$s-$layout.json" ] && continue
    /usr/bin/time -f "$s $layout: %e s, %M KB" \
      "$cgv" eval "$dir" --grid "$grid" --codecs cgv --surface-every 2 "${flag[@]}" \
      --json "$out/$s-$layout.json" > "$out/$s-$layout.log" 2>&1
    tail -1 "$out/$s-$layout.log"
  done
  "$cgv" bdrate "$out/$s-world.json" "$out/$s-normal.json" | tee "$out/$s-bdrate.txt"
done
