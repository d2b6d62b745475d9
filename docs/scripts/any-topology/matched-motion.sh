#!/usr/bin/env bash
# Issue 17's cost target with the motion held equal: each open or multi-part
# sequence against samba, subsampled in time where needed until its frames
# move about as far apart and a velocity prediction misses them by about as much (python3 docs/scripts/any-topology/motion.py gives the per-frame
# step and the velocity prediction's miss, relative to the diagonal), the
# same frame count, the same grid and bitrates. Needs .data/SEQ/SEQ
# (samba, wolf, face-poses, horse-collapse). Writes out/matched/*.json;
# summary.py-like table: python3 docs/scripts/any-topology/matched.py.
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-${CARGO_TARGET_DIR:-target}/release/cgv}
out=out/matched
mkdir -p "$out"
samba_every() { # STEP FRAMES: .data/samba-every-STEP-FRAMES, links to every STEP-th samba frame
  local dir=.data/samba-every-$1-$2
  rm -rf "$dir" && mkdir -p "$dir"
  for ((j = 0; j < $2; j++)); do
    f=$(printf 'mesh_%04d.obj' $((j * $1)))
    [ -f ".data/samba/samba/$f" ] || { echo "no .data/samba/samba/$f (unpack samba first)" >&2; exit 1; }
    ln -s "$PWD/.data/samba/samba/$f" "$dir/$f"
  done
}
run() { # NAME INPUT SURFACE_EVERY KBPS [eval options]
  local name=$1 input=$2 every=$3 kbps=$4
  shift 4
  "$cgv" eval "$input" --grid 128 --codecs predictive --kbps "$kbps" --surface-every "$every" "$@" \
    --json "$out/$name.json" > "$out/$name.log" 2>&1
}
run wolf .data/wolf/wolf 1 150,260,450,900,1800
samba_every 20 6 && samba_every 8 9
run samba-every-20 .data/samba-every-20-6 1 150,260,450,900,1800
run face-poses .data/face-poses/face-poses 1 130,270,550,1100
run samba-every-8 .data/samba-every-8-9 1 130,270,550,1100
run horse-collapse .data/horse-collapse/horse-collapse 2 60,120,240,480 --frames 0..24
run samba-24 .data/samba/samba 2 60,120,240,480 --frames 0..24
for s in samba wolf face-poses horse-collapse horse-gallop pcow cylinder; do [ -d .data/$s/$s ] || exit 1; done
python3 docs/scripts/any-topology/motion.py .data/{samba,wolf,face-poses,horse-collapse,horse-gallop,pcow,cylinder}/* \
  .data/samba-every-20-6 .data/samba-every-8-9
python3 docs/scripts/any-topology/matched.py wolf:samba-every-20 face-poses:samba-every-8 horse-collapse:samba-24
