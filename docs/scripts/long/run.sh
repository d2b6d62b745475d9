#!/usr/bin/env bash
# Long motions: samba played back and forth (a folder of links to its 175
# OBJ frames) for 1 and 10 minutes at 30 fps, encoded at N = 128 and
# decoded, with each command's peak resident memory (GNU time).
# Needs samba unpacked as .data/samba/samba. Prints one line per run.
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-${CARGO_TARGET_DIR:-target}/release/cgv}
src=$PWD/.data/samba/samba
out=out/long
mkdir -p "$out"
for minutes in ${*:-1 10}; do
  n=$((minutes * 1800))
  dir=.data/samba-${minutes}min
  if [ ! -d "$dir" ] || [ "$(ls "$dir" | wc -l)" -ne "$n" ]; then
    rm -rf "$dir" && mkdir -p "$dir"
    for ((i = 0; i < n; i++)); do
      k=$((i % 348)); [ $k -ge 174 ] && k=$((348 - k))
      ln -s "$src/$(printf 'mesh_%04d.obj' $k)" "$dir/$(printf 'f%05d.obj' $i)"
    done
  fi
  for step in encode decode; do
    if [ $step = encode ]; then
      cmd=("$cgv" encode "$dir" --grid 128 --qp 30 -o "$out/samba-${minutes}min.cgv")
    else
      cmd=("$cgv" decode "$out/samba-${minutes}min.cgv" -o "$out/samba-${minutes}min-decoded" --mesh grid)
      rm -rf "$out/samba-${minutes}min-decoded"
    fi
    /usr/bin/time -f "%e %M" -o "$out/time-$step-$minutes" "${cmd[@]}" > "$out/$step-$minutes.log" 2>&1
    read -r secs kb < "$out/time-$step-$minutes"
    echo "samba ${minutes} min ($n frames) $step: ${secs} s, peak RSS $((kb / 1024)) MiB"
  done
done
