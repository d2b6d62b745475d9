#!/bin/bash
# The source-vertex floors with and without `--fit-places` (docs/RESULTS.md,
# "The input's own mesh", "Places fitted to the motion").
# Needs the sequences unpacked as .data/NAME/NAME (tar xJf ../shared/data/NAME.tar.xz -C .data/NAME).
cd "$(git -C "$(dirname "$0")" rev-parse --show-toplevel)" && mkdir -p out/fit
B=${CGV:-target/release/cgv}
for s in samba pcow horse-gallop horse-collapse face-poses wolf cylinder; do for n in 128 256; do for v in own fit; do
  o=""; [ $v = fit ] && o=--fit-places
  $B remesh .data/$s/$s -o out/fit/$s-$n.glb --grid $n --error-stride 5 $o --json > out/fit/$s-$n-$v.json 2>/dev/null || echo "$s $n $v FAILED"
done; done; done
python3 - <<'PY'
import json, os
print("| sequence | frames | N | vertex RMS, own places | fitted | vertex max, own | fitted | places moved | fitting s |")
print("|---|---|---|---|---|---|---|---|---|")
for s in "samba pcow horse-gallop horse-collapse face-poses wolf cylinder".split():
    for n in (128, 256):
        a, b = (f"out/fit/{s}-{n}-{v}.json" for v in ("own", "fit"))
        if not (os.path.exists(a) and os.path.exists(b)):
            continue
        a, b = json.load(open(a)), json.load(open(b))
        ea, eb = a["error"], b["error"]
        fit_s = b["seconds"]["locate_samples"] - a["seconds"]["locate_samples"]
        print(f"| {s} | {a['frames']} | {n} | {100*ea['vertex_rms_mean']:.4f} % | **{100*eb['vertex_rms_mean']:.4f} %** | "
              f"{100*ea['vertex_max_max']:.3f} % | {100*eb['vertex_max_max']:.3f} % | {b['places_moved']} of {b['input_vertices']} | {fit_s:.2f} |")
PY
