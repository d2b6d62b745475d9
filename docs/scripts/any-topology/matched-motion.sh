#!/usr/bin/env bash
# Issue 17's cost target with the motion held equal: each open or multi-part
# sequence against samba subsampled in time until its frames move about as
# far apart (python3 docs/scripts/any-topology/motion.py gives the per-frame
# step and the velocity prediction's miss, relative to the diagonal), the
# same frame count, the same grid and bitrates. Needs .data/SEQ/SEQ
# (samba, wolf, face-poses, horse-collapse). Writes out/matched/*.json;
# summary.py-like table: python3 docs/scripts/any-topology/matched.py.
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-${CARGO_TARGET_DIR:-target}/release/cgv}
out=out/matched
mkdir -p "$out"
samba_every() { # STEP FRAMES: a folder of links to every STEP-th samba frame
  local dir=.data/samba-every-$1-$2
  rm -rf "$dir" && mkdir -p "$dir"
  for ((j = 0; j < $2; j++)); do
    f=$(printf 'mesh_%04d.obj' $((j * $1)))
    ln -s "$PWD/.data/samba/samba/$f" "$dir/$f"
  done
  echo "$dir"
}
run() { # NAME INPUT SURFACE_EVERY KBPS [eval options]
  local name=$1 input=$2 every=$3 kbps=$4
  shift 4
  "$cgv" eval "$input" --grid 128 --codecs predictive --kbps "$kbps" --surface-every "$every" "$@" \
    --json "$out/$name.json" > "$out/$name.log" 2>&1
}
run wolf .data/wolf/wolf 1 150,260,450,900,1800
run samba-every-20 "$(samba_every 20 6)" 1 150,260,450,900,1800
run face-poses .data/face-poses/face-poses 1 130,270,550,1100
run samba-every-8 "$(samba_every 8 9)" 1 130,270,550,1100
run horse-collapse .data/horse-collapse/horse-collapse 2 60,120,240,480 --frames 0..24
run samba-every-5 "$(samba_every 5 24)" 2 60,120,240,480
python3 docs/scripts/any-topology/motion.py .data/wolf/wolf .data/samba-every-20-6 .data/face-poses/face-poses \
  .data/samba-every-8-9 .data/horse-collapse/horse-collapse .data/samba-every-5-24 .data/samba/samba
python3 docs/scripts/any-topology/matched.py wolf:samba-every-20 face-poses:samba-every-8 horse-collapse:samba-every-5
