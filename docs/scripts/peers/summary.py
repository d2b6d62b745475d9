"""Bits per input vertex per frame at equal surface RMS: each peer, and ours
at each grid size, with the input's mesh (the user's mesh out, like the
peers) and without it (the grid mesh out), read off each curve log-log
between neighbouring points, from `cgv eval --peers --json` reports.
Usage: summary.py REPORT.json ...  (one per sequence and grid).
Where mesh.sh left REPORT.mesh.json beside a report (the input's mesh as
today's encoder stores it), its bytes replace the report's."""

import json
import math
import os
import sys

LEVELS = [0.5, 0.2, 0.1, 0.05, 0.03, 0.02]  # percent of the diagonal


def bits_at(curve, error):
    """Fewest bits reaching `error` on (bits, error) points; None where the
    curve never gets there, or starts below it (not measured there)."""
    pts = sorted((b, e) for b, e in curve if b > 0 and e and e > 0)
    if not pts or pts[0][1] <= error:
        return None
    for (b0, e0), (b1, e1) in zip(pts, pts[1:]):
        if e1 <= error:
            t = (math.log(e0) - math.log(error)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(b0) + t * (math.log(b1) - math.log(b0)))
    return None


def main(paths):
    seqs = {}
    for p in paths:
        r = json.load(open(p))
        mesh = p[: -len(".json")] + ".mesh.json"
        if os.path.exists(mesh):
            r["source_mesh_bytes"] = json.load(open(mesh))["source_mesh_bytes"]
        s = seqs.setdefault(r["input"], {"ours": {}, "peers": None, "frames": r["frames"], "vertices": r["input_vertices"]})
        scale = 8.0 / (r["frames"] * r["input_vertices"])
        ours = [((c["bytes"] + r["source_mesh_bytes"]) * scale, c["surface_rms"]) for q in r["points"] for c in q["results"]]
        grid = [(c["bytes"] * scale, c["surface_rms"]) for q in r["points"] for c in q["results"]]
        s["ours"][r["grid"]] = (ours, min(e for _, e in ours), r["source_mesh_bytes"] * scale, grid)
        if r.get("peers"):
            s["peers"] = {c["name"]: [(q["bits_per_input_vertex"], q["surface_rms"]) for q in c["points"]] for c in r["peers"]["report"]["curves"]}
    for name, s in seqs.items():
        grids = sorted(s["ours"])
        print(f"\n#### {name.rstrip('/').split('/')[-1]} ({s['frames']} frames, {s['vertices']} vertices); our lowest surface RMS: "
              + ", ".join(f"N = {n}: {100 * s['ours'][n][1]:.4f} %" for n in grids)
              + "; the input's mesh adds " + ", ".join(f"{s['ours'][n][2]:.2f}" for n in grids[:1]) + " bits/vertex/frame\n")
        peers = list(s["peers"] or {})
        print("| surface RMS | " + " | ".join(peers) + " | better peer | " + " | ".join(f"ours N = {n}" for n in grids)
              + " | better peer / ours | " + " | ".join(f"ours N = {n}, grid mesh out" for n in grids) + " | better peer / ours, grid mesh out |")
        print("|---" * (len(peers) + 2 * len(grids) + 4) + "|")
        for level in LEVELS:
            e = level / 100
            pb = [bits_at(s["peers"][p], e) for p in peers]
            ob = [bits_at(s["ours"][n][0], e) for n in grids]
            gb = [bits_at(s["ours"][n][3], e) for n in grids]
            best_peer = min((b for b in pb if b), default=None)
            cell = lambda b: f"{b:.2f}" if b else "–"

            def ratio(bits):
                best_ours = min((b for b in bits if b), default=None)
                if best_peer and best_ours:
                    q = best_peer / best_ours
                    return f"{q:.2f}x fewer" if q >= 1 else f"**{1 / q:.2f}x more**"
                return "**below our floor**" if best_peer else "–"

            print(f"| {level} % | " + " | ".join(map(cell, pb)) + f" | {cell(best_peer)} | " + " | ".join(map(cell, ob))
                  + f" | {ratio(ob)} | " + " | ".join(map(cell, gb)) + f" | {ratio(gb)} |")


if __name__ == "__main__":
    main(sys.argv[1:])
