"""The matched-motion table: for each SEQ:REFERENCE pair of out/matched/*.json
(cgv eval reports), each of SEQ's points beside the bits the reference needs
for the same surface RMS, read off its curve log-log between neighbouring
points ("-" outside it); per input vertex and per grid sample, a frame."""

import json
import math
import sys


def points(name):
    with open(f"out/matched/{name}.json") as f:
        report = json.load(f)
    rows = [p["results"][0] for p in report["points"]]
    return sorted((r["surface_rms"], r["bits_per_input_vertex"], r["bits_per_grid_sample"]) for r in rows)


def at(curve, rms, column):
    for (e0, *b0), (e1, *b1) in zip(curve, curve[1:]):
        if e0 <= rms <= e1 and e0 < e1:
            t = math.log(rms / e0) / math.log(e1 / e0)
            return math.exp(math.log(b0[column]) + t * (math.log(b1[column]) - math.log(b0[column])))
    return None


for pair in sys.argv[1:]:
    seq, ref = pair.split(":")
    ours, theirs = points(seq), points(ref)
    print(f"\n{seq} against {ref}\n")
    print("| surface RMS | b/v/f | reference's b/v/f there | ratio | bits/sample | reference's | ratio |")
    print("|---|---|---|---|---|---|---|")
    for rms, bv, bs in ours:
        rv, rs = at(theirs, rms, 0), at(theirs, rms, 1)
        cell = lambda x, y: ("-", "-") if y is None else (f"{y:.2f}", f"{x / y:.2f}x")
        (v, vr), (s, sr) = cell(bv, rv), cell(bs, rs)
        print(f"| {100 * rms:.3f} % | {bv:.2f} | {v} | {vr} | {bs:.2f} | {s} | {sr} |")
