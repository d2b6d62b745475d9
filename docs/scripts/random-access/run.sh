#!/usr/bin/env bash
# What random-access points cost: `cgv eval` of the cgv codec with no point
# but frame 0 (--random-access 0) and with one every S seconds, on each
# sequence named (unpacked in .data/), at N = 128, the five preset rate
# points, surface distance every 2nd frame; then the BD-rate of the second
# against the first. Usage: run.sh SECONDS SEQUENCE...
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-${CARGO_TARGET_DIR:-target}/release/cgv}
seconds=$1; shift
out=out/random-access
mkdir -p "$out"
for name in "$@"; do
  dir=.data/$name
  [ -d "$dir/$name" ] && dir=$dir/$name   # the archive's own folder, as tar xJf leaves it
  for s in 0 "$seconds"; do
    json="$out/$name-128-ra$s.json"
    [ -f "$json" ] || "$cgv" eval "$dir" --grid 128 --codecs predictive --surface-every 2 --random-access "$s" \
      --json "$json" > "$out/$name-128-ra$s.log" 2>&1
  done
  echo "== $name, N = 128: points every $seconds s against none"
  "$cgv" bdrate "$out/$name-128-ra0.json" "$out/$name-128-ra$seconds.json"
done
