"""How far a motion's frames are apart: the RMS per-frame step of its vertices
and the RMS miss of a velocity prediction 2x(t-1) - x(t-2), relative to the
first frame's bounding-box diagonal, over the first 24 frames of each OBJ folder.
Usage: python3 motion.py FOLDER... (numpy)."""

import os
import re
import sys

import numpy as np


def load(path):
    with open(path) as f:
        return np.array([[float(x) for x in line.split()[1:4]] for line in f if line.startswith("v ")])


for folder in sys.argv[1:]:
    # Natural order, as cgv reads a folder (2.obj before 10.obj).
    key = lambda n: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", n)]
    names = sorted((n for n in os.listdir(folder) if n.endswith(".obj")), key=key)
    frames = [load(os.path.join(folder, n)) for n in names[:24]]
    diagonal = np.linalg.norm(frames[0].max(0) - frames[0].min(0))
    rms = lambda d: np.sqrt((d**2).sum(1).mean()) / diagonal
    step = np.mean([rms(b - a) for a, b in zip(frames, frames[1:])])
    miss = np.mean([rms(frames[t] - 2 * frames[t - 1] + frames[t - 2]) for t in range(2, len(frames))] or [0])
    print(f"{folder}: {len(names)} frames, {len(frames[0])} vertices; step {100 * step:.3f} %, "
          f"velocity prediction's miss {100 * miss:.3f} % (first {len(frames)} frames)")
