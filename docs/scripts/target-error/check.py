"""One --target-error result: asked, kept QP, size, the encoder's figure, and every frame's surface RMS."""
import json
import sys

import numpy as np

import cgv

motion, path, report, target = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
positions, faces, fps = cgv.read_motion(motion)
data = open(path, "rb").read()
grid, gfaces = cgv.decode(data, mesh="grid")
diag = cgv.diagonal(positions[0])
rms = [cgv.surface_distance(grid[f], gfaces, positions[f], faces)["rms"] / diag for f in range(len(positions))]
r = json.load(open(report))
t = r["target"]
print(f"target {target:.3f} %: QP {t['qp']}, {r['kbps']:.1f} kbit/s ({r['bytes']} bytes, {t['encodes']} encodes), "
      f"encoder's 12 frames {100 * t['surface_rms']:.4f} %, all {len(rms)} frames {100 * np.mean(rms):.4f} % "
      f"(worst frame {100 * max(rms):.4f} %)")
