"""Draco on every frame of an unregistered capture (the users' alternative
to `cgv encode --unregistered`), measured against the registered truth the
capture was made from (RESULTS, "Captures without correspondence").

Each frame of the capture (a folder of OBJ files, each its own mesh, as
`cgv unregister` writes) is compressed on its own by Draco at each
quantization, decoded, and its surface distance to the same frame of the
registered sequence measured as `cgv eval` does (symmetric, area-weighted
RMS over the frames, relative to frame 0's bounding-box diagonal). Bits are
per *original* vertex per frame, the units of the table there.

    python docs/scripts/unregistered/draco.py CAPTURE TRUTH --frames 0..24 [--json out.json]

Needs DracoPy and the cgv Python package (pkg-scripts/setup.sh puts both
in ~/.cache/cgv/venv).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np

import cgv
import obj_frames
from obj_frames import frame_files

DRACO_BITS = [6, 7, 8, 9, 10, 11, 12, 14]


def read_obj(path: pathlib.Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions (float32) and triangles (uint32) of a plain OBJ file, as DracoPy takes them."""
    v, f = obj_frames.read_obj(path)
    return v.astype(np.float32), f.astype(np.uint32)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("capture", type=pathlib.Path, help="the unregistered capture (OBJ frames)")
    ap.add_argument("truth", type=pathlib.Path, help="the registered sequence it was made from (OBJ frames)")
    ap.add_argument("--frames", default=None, help="A..B of the truth the capture holds (default: from 0)")
    ap.add_argument("--bits", default=",".join(map(str, DRACO_BITS)), help="Draco quantization bits to try")
    ap.add_argument("--json", type=pathlib.Path)
    args = ap.parse_args(argv)
    try:
        import DracoPy
    except ImportError:
        print("needs DracoPy: pip install DracoPy", file=sys.stderr)
        return 2
    capture, truth = frame_files(args.capture), frame_files(args.truth)
    start = int(args.frames.split("..")[0]) if args.frames else 0
    if not capture or len(truth) < start + len(capture):
        print(f"{args.capture}: {len(capture)} frames, {args.truth}: {len(truth)} from {start}", file=sys.stderr)
        return 2
    frames = [read_obj(p) for p in capture]
    originals = [read_obj(p) for p in truth[start : start + len(capture)]]
    diagonal = float(np.linalg.norm(originals[0][0].max(0) - originals[0][0].min(0)))
    vertices = originals[0][0].shape[0]
    points = []
    for q in [int(b) for b in args.bits.split(",")]:
        size, rms = 0, []
        for (pos, faces), (opos, ofaces) in zip(frames, originals):
            data = DracoPy.encode(pos, faces, quantization_bits=q, compression_level=10)
            size += len(data)
            mesh = DracoPy.decode(data)
            dpos = np.ascontiguousarray(np.asarray(mesh.points, dtype=np.float32).reshape(-1, 3))
            dfaces = np.ascontiguousarray(np.asarray(mesh.faces, dtype=np.uint32).reshape(-1, 3))
            d = cgv.surface_distance(dpos, dfaces, np.ascontiguousarray(opos), np.ascontiguousarray(ofaces))
            rms.append(d["rms"] / diagonal)
        bits = size * 8.0 / (len(frames) * vertices)
        points.append({"setting": f"q={q}", "bytes": size, "bits_per_original_vertex": bits, "surface_rms": float(np.mean(rms))})
        print(f"draco q={q}: {bits:.2f} bits per original vertex per frame, surface RMS {100 * np.mean(rms):.4f} %")
    if args.json:
        args.json.write_text(json.dumps({"capture": str(args.capture), "truth": str(args.truth), "frames": len(frames), "original_vertices": vertices, "points": points}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
