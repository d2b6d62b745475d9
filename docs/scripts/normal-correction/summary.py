#!/usr/bin/env python3
"""Tables for docs/RESULTS.md from docs/scripts/normal-correction/run.sh's
reports: per rate point, the project's codec with x, y, z at full size
(world) and with x, y, z halved plus the normal picture (normal)."""
import json, sys, glob, os

def load(p):
    return json.load(open(p)) if os.path.exists(p) else None

def pct(x):
    return f"{100 * x:.3f}" if x is not None else "–"

for grid_dir in sorted(glob.glob("out/normal/*")):
    grid = os.path.basename(grid_dir)
    for w in sorted(glob.glob(f"{grid_dir}/*-world.json")):
        name = os.path.basename(w)[: -len("-world.json")]
        a, b = load(w), load(w.replace("-world.json", "-normal.json"))
        if not b:
            continue
        print(f"\n**{name}**, N = {grid}, {a['frames']} frames:\n")
        print("| rate point | kbit/s @30 fps (world / normal) | mode, QP (world / normal) | surface RMS % (world / normal) | vertex RMS % | spacing drift, worst frame % | dn share of the video bytes |")
        print("|---|---|---|---|---|---|---|")
        for pa, pb in zip(a["points"], b["points"]):
            ra, rb = pa["results"][0], pb["results"][0]
            mode = lambda r: f"{r.get('corrections') or '-'}{'/2' if r.get('correction_interval') == 2 else ''} {r['qp']}{'+L2' if r['layers'] == 2 else ''}"
            sb = dict((k, v) for k, v in rb.get("stream_bytes", []))
            video = sum(v for k, v in sb.items() if not k.startswith("seed"))
            share = f"{100 * sb.get('dn', 0) / video:.0f} %" if video else "–"
            drift = lambda r: f"{100 * r['spacing_drift_worst']:.1f}" if "spacing_drift_worst" in r else "–"
            print(f"| {pa['name'].split(' ')[0]} | {ra['kbps_30fps']:.0f} / {rb['kbps_30fps']:.0f} | {mode(ra)} / {mode(rb)} | "
                  f"{pct(ra['surface_rms'])} / {pct(rb['surface_rms'])} | {pct(ra['vertex_rms'])} / {pct(rb['vertex_rms'])} | "
                  f"{drift(ra)} / {drift(rb)} | {share} |")
        bd = open(w.replace("-world.json", "-bdrate.txt")).read() if os.path.exists(w.replace("-world.json", "-bdrate.txt")) else ""
        for line in bd.splitlines():
            if line.strip().startswith(("surface_rms", "vertex_rms")):
                print(f"\nBD-rate, normal against world, {line.split()[0]}: one cubic {line.split()[1]} %, piecewise {line.split()[3]} %", end="")
        print()
