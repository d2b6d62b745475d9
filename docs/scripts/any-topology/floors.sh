#!/bin/bash
# The source-vertex floors of docs/RESULTS.md ("The input's own mesh"), format v7.
cd "$(git -C "$(dirname "$0")" rev-parse --show-toplevel)" && mkdir -p out/any
# Needs the sequences unpacked as .data/NAME/NAME (tar xJf ../shared/data/NAME.tar.xz -C .data/NAME).
B=target/release/cgv
for s in samba pcow horse-gallop horse-collapse face-poses wolf cylinder; do for n in 128 256; do
  $B remesh .data/$s/$s -o out/any/rm-$s-$n.glb --grid $n --error-stride 5 --json > out/any/rm-$s-$n.json 2>/dev/null || echo "$s $n FAILED"
done; done
for g in RiggedFigure Fox; do for n in 64 128; do
  $B remesh ../shared/data/gltf/$g.gltf -o out/any/rm-$g-$n.glb --grid $n --json > out/any/rm-$g-$n.json 2>/dev/null || echo "$g $n FAILED"
done; done
echo floors done
