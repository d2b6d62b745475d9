#!/usr/bin/env bash
# cgv eval on long motions (samba played back and forth, as run.sh makes
# them): its peak resident memory (GNU time) with the frames held (1 minute
# fits the default 512 MiB) and read again on each pass (--in-memory-mib 0,
# and 10 minutes, past the budget). One codec (GV), one rate point, N = 64,
# no surface distances: the memory, not the figures, is measured here.
# Run docs/scripts/long/run.sh first (it makes the folders of links).
set -euo pipefail
cd "$(dirname "$0")/../../.."
cgv=${CGV:-${CARGO_TARGET_DIR:-target}/release/cgv}
out=out/long
mkdir -p "$out"
run() {
  local name=$1; shift
  /usr/bin/time -f "%e %M" -o "$out/time-eval-$name" "$cgv" eval "$@" --grid 64 --codecs gv --kbps 150 \
    --surface-every 0 --json "$out/eval-$name.json" > "$out/eval-$name.log" 2>&1
  read -r secs kb < "$out/time-eval-$name"
  echo "cgv eval $name: ${secs} s, peak RSS $((kb / 1024)) MiB"
}
run 1min-held .data/samba-1min
run 1min-read .data/samba-1min --in-memory-mib 0
run 10min-read .data/samba-10min
