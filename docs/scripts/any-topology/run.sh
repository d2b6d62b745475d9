#!/bin/bash
# The any-topology figures of docs/RESULTS.md: every shared sequence at N = 128 and 256.
cd "$(git -C "$(dirname "$0")" rev-parse --show-toplevel)" && mkdir -p out/any
# Needs the sequences unpacked as .data/NAME/NAME (tar xJf ../shared/data/NAME.tar.xz -C .data/NAME).
B=target/release/cgv
for n in 128 256; do
for s in cylinder wolf face-poses horse-collapse horse-gallop pcow samba; do
  in=.data/$s/$s
  [ -d $in ] || in=$(ls -d .data/$s/* | head -1)
  fr=""; case $s in horse-collapse|horse-gallop|pcow|samba) fr="--frames 0..24";; esac
  /usr/bin/time -f "$s $n: %e s, %M KB" $B eval $in --grid $n $fr --codecs predictive --rates low,medium,high --surface-every 4 --json out/any/$s-$n.json > out/any/$s-$n.log 2>&1 || echo "$s $n FAILED"
  tail -1 out/any/$s-$n.log
done; done
