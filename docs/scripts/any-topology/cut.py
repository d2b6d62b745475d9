"""Cuts a closed OBJ motion open, to measure what borders cost with the motion
and the surface held equal: the same frames with faces taken out, chosen once
on the first frame.

  parts: faces whose centroid's height lies in one of two bands (a neck and a
         waist, as fractions of the height) are removed, so the body falls
         into several parts, each with open edges;
  holes: faces within a radius of six vertices spread over the body are
         removed, so the surface stays one part with six holes.

Unused vertices are dropped. Usage:
  python3 cut.py parts|holes IN_FOLDER OUT_FOLDER [FRAMES]
(plain Python; FRAMES: the first so many frames, default all)."""

import os
import re
import sys


def read(path):
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
    return verts, faces


def centroid(verts, face):
    return [sum(verts[i][a] for i in face) / len(face) for a in range(3)]


def removed_by_bands(verts, faces):
    lo = min(v[1] for v in verts)
    height = max(v[1] for v in verts) - lo
    bands = [(0.53, 0.55), (0.82, 0.84)]
    def cut(face):
        y = (centroid(verts, face)[1] - lo) / height
        return any(a <= y <= b for a, b in bands)
    return [cut(face) for face in faces]


def removed_by_holes(verts, faces):
    # Six centres spread by farthest-point sampling from vertex 0; radius 2 %
    # of the bounding-box diagonal.
    lo = [min(v[a] for v in verts) for a in range(3)]
    hi = [max(v[a] for v in verts) for a in range(3)]
    radius = 0.02 * sum((h - l) ** 2 for h, l in zip(hi, lo)) ** 0.5
    d2 = lambda p, q: sum((a - b) ** 2 for a, b in zip(p, q))
    centres = [verts[0]]
    nearest = [d2(v, centres[0]) for v in verts]
    while len(centres) < 6:
        far = max(range(len(verts)), key=nearest.__getitem__)
        centres.append(verts[far])
        nearest = [min(n, d2(v, verts[far])) for n, v in zip(nearest, verts)]
    return [any(d2(centroid(verts, f), c) < radius**2 for c in centres) for f in faces]


def main():
    mode, src, dst = sys.argv[1:4]
    key = lambda n: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", n)]
    names = sorted((n for n in os.listdir(src) if n.endswith(".obj")), key=key)
    if len(sys.argv) > 4:
        names = names[: int(sys.argv[4])]
    verts, faces = read(os.path.join(src, names[0]))
    removed = {"parts": removed_by_bands, "holes": removed_by_holes}[mode](verts, faces)
    kept = [f for f, r in zip(faces, removed) if not r]
    used = sorted({i for f in kept for i in f})
    new = {old: k for k, old in enumerate(used)}
    face_lines = "".join("f " + " ".join(str(new[i] + 1) for i in f) + "\n" for f in kept)
    os.makedirs(dst, exist_ok=True)
    for name in names:
        verts, _ = read(os.path.join(src, name))
        with open(os.path.join(dst, name), "w") as out:
            out.write("".join("v %.7g %.7g %.7g\n" % tuple(verts[i]) for i in used))
            out.write(face_lines)
    print(f"{dst}: {len(names)} frames, {len(used)} of {len(verts)} vertices, "
          f"{len(kept)} of {len(faces)} faces kept")


main()
