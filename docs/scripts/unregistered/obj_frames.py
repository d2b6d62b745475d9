"""Plain OBJ frames for the scripts beside this one: a frame's positions
and triangles, and a folder's frames in order."""

from __future__ import annotations

import pathlib
import re

import numpy as np


def read_obj(path: pathlib.Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions (float64) and triangles (int64, fans split) of a plain OBJ file (`v` and `f` lines)."""
    v, f = [], []
    for line in path.read_text().splitlines():
        if line.startswith("v "):
            v.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
            f.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64).reshape(-1, 3)


def frame_files(folder: pathlib.Path) -> list[pathlib.Path]:
    """The OBJ files of a folder, ordered by the last number in the name."""
    files = [p for p in folder.iterdir() if p.suffix.lower() == ".obj"]
    return sorted(files, key=lambda p: int((re.findall(r"\d+", p.stem) or ["0"])[-1]))
