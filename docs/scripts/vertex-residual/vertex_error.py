"""Vertex RMS of decoded OBJ frames against the input's, relative to the first
frame's bounding-box diagonal: prints bytes, bits per vertex per frame, the
RMS over all frames (%) and the worst frame's (%).

Usage: python3 vertex_error.py INPUT_DIR DECODED_DIR FRAMES FILE_BYTES
"""
import math
import os
import re
import sys


def vertices(path):
    with open(path) as f:
        return [tuple(map(float, line.split()[1:4])) for line in f if line.startswith("v ")]


def main():
    src, dec, frames, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    inputs = sorted((p for p in os.listdir(src) if p.endswith(".obj")), key=lambda p: int(re.findall(r"\d+", p)[0]))
    first = vertices(os.path.join(src, inputs[0]))
    diag = math.dist([min(c) for c in zip(*first)], [max(c) for c in zip(*first)])
    total, worst = 0.0, 0.0
    for k in range(frames):
        truth = vertices(os.path.join(src, inputs[k]))
        got = vertices(os.path.join(dec, f"frame_{k:04d}.obj"))
        mse = sum(math.dist(a, b) ** 2 for a, b in zip(truth, got)) / len(truth)
        total += mse
        worst = max(worst, math.sqrt(mse))
    bits = size * 8 / (len(first) * frames)
    print(f"{size}\t{bits:.3f}\t{100 * math.sqrt(total / frames) / diag:.4f}\t{100 * worst / diag:.4f}")


main()
