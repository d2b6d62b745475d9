"""How far a registered motion is from isometric: how much its edges
stretch from frame to frame and against frame 0 (RESULTS, "Captures
without correspondence"). A capture's features and map are intrinsic (the
heat kernel signature, the conformal map): where the body's own lengths
change, a map made from each frame's shape alone moves on the body.

    python docs/scripts/unregistered/isometry.py SEQUENCE_FOLDER [--frames 24]

Prints, averaged over the frames: the median of |l / l_before - 1| over the
edges and the length-weighted change sqrt(sum (l - l_before)^2 / sum
l_before^2), the same against frame 0, and how many edges change by more
than 1 % of the bounding-box diagonal against frame 0 at the worst frame.
"""

from __future__ import annotations

import argparse
import pathlib

import numpy as np
from obj_frames import frame_files, read_obj


def weighted(a: np.ndarray, b: np.ndarray) -> float:
    """The length-weighted change from lengths b to a."""
    return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b**2)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=pathlib.Path, help="a registered motion: OBJ frames sharing one mesh")
    ap.add_argument("--frames", type=int, default=24, help="the first this many frames")
    args = ap.parse_args()
    files = frame_files(args.folder)[: args.frames]
    if len(files) < 2:
        raise SystemExit(f"{args.folder}: fewer than two OBJ frames")
    v0, faces = read_obj(files[0])
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1), axis=0)
    diag = np.linalg.norm(v0.max(0) - v0.min(0))

    def lengths(v: np.ndarray) -> np.ndarray:
        return np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)

    l0 = before = lengths(v0)
    rows, worst_count = [], 0
    for path in files[1:]:
        v, f = read_obj(path)
        if len(v) != len(v0) or not np.array_equal(f, faces):
            raise SystemExit(f"{path}: not the same mesh as {files[0]} (a registered motion is needed)")
        l = lengths(v)
        rows.append((np.median(np.abs(l / before - 1)), weighted(l, before), np.median(np.abs(l / l0 - 1)), weighted(l, l0)))
        worst_count = max(worst_count, int(np.sum(np.abs(l - l0) > 0.01 * diag)))
        before = l
    m = np.mean(rows, axis=0) * 100
    print(
        f"{args.folder.name}: {len(files)} frames, {len(edges)} edges; frame to frame: median {m[0]:.2f} %, "
        f"length-weighted {m[1]:.2f} %; against frame 0: median {m[2]:.2f} %, length-weighted {m[3]:.2f} %; "
        f"edges changing by more than 1 % of the diagonal (worst frame): {worst_count}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
