#!/usr/bin/env bash
# --kbps kept by the whole file: `cgv encode --kbps` for both codecs on the
# shared sequences at three budgets, without the source mesh (it is the
# same for both codecs and would be most of a short clip's budget).
# Prints: sequence codec asked made(kbit/s) off(%) or the refusal.
# GRID (128) sets the grid, CODECS ("cgv gv") the codecs, CGV the binary:
#   GRID=256 bash docs/scripts/budget/run.sh
#   CODECS=conformal bash docs/scripts/budget/run.sh
set -uo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-./target/release/cgv}
grid=${GRID:-128}
out=out/budget
mkdir -p "$out"
for s in ${*:-samba pcow horse-gallop}; do
  for codec in ${CODECS:-cgv gv}; do
    for kbps in 300 600 1200; do
      if r=$("$cgv" encode ".data/$s/$s" --grid "$grid" --codec "$codec" --kbps "$kbps" --no-source-mesh \
          -o "$out/$s-$codec-$grid-$kbps.cgv" --json 2>"$out/$s-$codec-$grid-$kbps.err"); then
        echo "$r" | python3 -c "import json,sys; r=json.load(sys.stdin); k=r['kbps']; print(f'$s N=$grid $codec $kbps {k:.1f} {100*(k/$kbps-1):+.1f}% {r[\"report\"][\"passes\"]} passes, {r[\"report\"][\"seconds_total\"]:.1f} s')"
      else
        echo "$s N=$grid $codec $kbps refused: $(tail -1 "$out/$s-$codec-$grid-$kbps.err")"
      fi
    done
  done
done
