"""What users ship today, measured as ``cgv eval`` measures us.

Two peers, on the same frames of the same input:

- **Draco, every frame on its own** (DracoPy: ``encode(points, faces,
  quantization_bits=q, compression_level=10)``, edgebreaker), sizes summed
  over the frames, as a player fetching one ``.drc`` per frame receives them.
- **gltfpack morph targets** (the npm ``gltfpack``): frame 0 is the base
  mesh, every later frame a morph target, played by a STEP weights
  animation; ``gltfpack -vp B -cc`` or ``-cz``, then ``gzip -9`` (what a
  server sends). The file is decoded for real: its compressed buffer views
  by meshoptimizer's own decoder (Node), then its quantized accessors and
  the node transform that dequantizes them here.

Both are compared with the input frames by cgv's own surface distance
(:func:`cgv.surface_distance`: symmetric, area-weighted RMS and max),
divided by the first frame's bounding-box diagonal, the RMS averaged over
the measured frames and the max the largest: the ``surface_rms`` and
``surface_max`` of ``cgv eval --json``. Both tools reorder vertices and may
merge them, so each input vertex is matched to the decoded vertex whose
trajectory (over up to 16 frames) is nearest, and the vertex RMSE is
measured on that match.

Run it, then give the JSON to ``cgv eval --peers``, which puts the peers on
its chart and tables and says how many bits we need where they are::

    python -m cgv.peers data/samba --frames 0..60 --json samba-peers.json
    cgv eval data/samba --frames 0..60 --codecs predictive --peers samba-peers.json --md samba.md

It needs DracoPy (``pip install DracoPy``) and Node with the ``gltfpack``
and ``meshoptimizer`` packages (``--node-modules`` or ``CGV_NODE_MODULES``: the
``node_modules`` folder holding both; in a checkout, ``tests/node/node_modules``).
"""

from __future__ import annotations

import argparse
import gzip
import importlib.metadata
import json
import os
import pathlib
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np

from . import _native as native

#: Draco's quantization bits and gltfpack's ``-vp`` bits measured by default.
DRACO_BITS = (8, 9, 10, 11, 12, 14)
GLTFPACK_BITS = (8, 10, 12, 14)
GLTFPACK_MODES = ("cc", "cz")

_DECODE_JS = pathlib.Path(__file__).with_name("meshopt_decode.mjs")
_CHECKOUT_MODULES = pathlib.Path(__file__).resolve().parents[2] / "tests" / "node" / "node_modules"


class PeerError(RuntimeError):
    """A peer tool is missing, failed, or gave something this module cannot read."""


# ---------------------------------------------------------------- measuring


def match_trajectories(original: np.ndarray, decoded: np.ndarray, frames: int = 16) -> np.ndarray:
    """For each input vertex, the decoded vertex nearest to it over up to
    `frames` frames spread over the motion (both arrays (F, V, 3))."""
    pick = np.unique(np.linspace(0, original.shape[0] - 1, min(frames, original.shape[0])).round().astype(int))
    a = original[pick].transpose(1, 0, 2).reshape(original.shape[1], -1).astype(np.float64)
    b = decoded[pick].transpose(1, 0, 2).reshape(decoded.shape[1], -1).astype(np.float64)
    bb = (b * b).sum(1)
    out = np.empty(a.shape[0], dtype=np.int64)
    block = max(1, 4_000_000 // max(1, b.shape[0]))  # about 32 MB of distances at a time
    for s in range(0, a.shape[0], block):
        out[s : s + block] = (bb[None, :] - 2.0 * a[s : s + block] @ b.T).argmin(1)
    return out


def measure(original, faces, decoded, decoded_faces, diagonal, surface_every):
    """The errors of decoded frames (F, V', 3) with their faces against the
    input frames (F, V, 3), relative to `diagonal`, as ``cgv eval`` reports
    them: RMS figures the mean over frames, max figures the largest."""
    match = match_trajectories(original, decoded)
    vertex_rms, vertex_max, surface_rms, surface_max = [], 0.0, [], 0.0
    for t in range(original.shape[0]):
        rms, worst = native.vertex_error(original[t], np.ascontiguousarray(decoded[t][match]))
        vertex_rms.append(rms / diagonal)
        vertex_max = max(vertex_max, worst / diagonal)
        if surface_every and t % surface_every == 0:
            d = native.surface_distance(np.ascontiguousarray(decoded[t]), decoded_faces, original[t], faces)
            surface_rms.append(d["rms"] / diagonal)
            surface_max = max(surface_max, d["max"] / diagonal)
    return {
        "vertex_rms": float(np.mean(vertex_rms)),
        "vertex_max": float(vertex_max),
        "surface_rms": float(np.mean(surface_rms)) if surface_rms else None,
        "surface_max": float(surface_max) if surface_rms else None,
    }


def point(setting, size, frames, vertices, errors, seconds):
    """One rate point, in the units of ``cgv eval --json``."""
    return {
        "setting": setting,
        "bytes": int(size),
        "kbps_30fps": size * 8.0 / 1000.0 * 30.0 / frames,
        "bits_per_input_vertex": size * 8.0 / (frames * vertices),
        **errors,
        "seconds": round(seconds, 3),
    }


# ---------------------------------------------------------------- Draco


def draco_curve(positions, faces, diagonal, bits=DRACO_BITS, surface_every=1, progress=print):
    try:
        import DracoPy
    except ImportError as e:
        raise PeerError("Draco needs DracoPy: pip install DracoPy") from e
    frames, vertices, _ = positions.shape
    points = []
    for q in bits:
        t0 = time.perf_counter()
        size, decoded, decoded_faces = 0, [], None
        for t in range(frames):
            data = DracoPy.encode(positions[t], faces, quantization_bits=q, compression_level=10)
            size += len(data)
            mesh = DracoPy.decode(data)
            f = np.asarray(mesh.faces, dtype=np.uint32).reshape(-1, 3)
            if decoded_faces is None:
                decoded_faces = f
            elif not np.array_equal(decoded_faces, f):
                # The trajectory matching needs one vertex order for the motion.
                raise PeerError(f"Draco q={q}: frame {t} came back in another vertex order than the first")
            decoded.append(np.asarray(mesh.points, dtype=np.float32).reshape(-1, 3))
        errors = measure(positions, faces, np.stack(decoded), decoded_faces, diagonal, surface_every)
        points.append(point(f"q={q}", size, frames, vertices, errors, time.perf_counter() - t0))
        progress(f"draco q={q}: {points[-1]['bits_per_input_vertex']:.2f} bits per vertex per frame")
    version = importlib.metadata.version("DracoPy")
    return {
        "name": "draco",
        "description": f"Draco (DracoPy {version}) on every frame, compression level 10, sizes summed over the frames",
        "points": points,
    }


# ---------------------------------------------------------------- glTF


def _pad(b: bytes, fill: bytes = b"\0") -> bytes:
    return b + fill * ((4 - len(b) % 4) % 4)


#: The morph animation's clock: gltfpack resamples every animation at 30 Hz
#: (``-af``, linearly), so frame t is keyed at t / 30 whatever the motion's
#: frame rate, and every key lands on a sample (the times do not change the
#: sizes).
TIMELINE_HZ = 30.0


def morph_glb(positions: np.ndarray, faces: np.ndarray) -> bytes:
    """A GLB of the motion as morph targets: frame 0 the base mesh, frame t
    (t >= 1) target t-1, switched on at t / TIMELINE_HZ by a STEP weights
    animation."""
    frames = positions.shape[0]
    chunks, views, accessors = [], [], []

    def add(array, component, kind, target=None, bounds=False):
        data = np.ascontiguousarray(array).tobytes()
        offset = sum(len(c) for c in chunks)
        chunks.append(_pad(data))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(data), **({"target": target} if target else {})})
        flat = np.asarray(array).reshape(len(array), -1)
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": len(array), "type": kind}
        if bounds:
            acc["min"], acc["max"] = flat.min(0).tolist(), flat.max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    base = positions[0].astype(np.float32)
    primitive = {
        "attributes": {"POSITION": add(base, 5126, "VEC3", 34962, True)},
        "indices": add(faces.astype(np.uint32).reshape(-1), 5125, "SCALAR", 34963),
        "targets": [{"POSITION": add((positions[t] - base).astype(np.float32), 5126, "VEC3", 34962, True)} for t in range(1, frames)],
    }
    weights = np.zeros((frames, frames - 1), dtype=np.float32)
    weights[np.arange(1, frames), np.arange(frames - 1)] = 1.0
    times = add((np.arange(frames) / TIMELINE_HZ).astype(np.float32), 5126, "SCALAR", bounds=True)
    values = add(weights.reshape(-1), 5126, "SCALAR")
    gltf = {
        "asset": {"version": "2.0", "generator": "cgv.peers"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [primitive], "weights": [0.0] * (frames - 1)}],
        "animations": [{"samplers": [{"input": times, "output": values, "interpolation": "STEP"}], "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}]}],
        "buffers": [{"byteLength": sum(len(c) for c in chunks)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    js = _pad(json.dumps(gltf).encode(), b" ")
    binary = b"".join(chunks)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary


_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NORMALIZED = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(gltf: dict, binary: bytes, index: int) -> np.ndarray:
    """An accessor's values as float64 (count, width), normalization applied."""
    a = gltf["accessors"][index]
    if "sparse" in a or "bufferView" not in a:
        raise PeerError(f"accessor {index}: sparse or empty accessors are not read here")
    if a.get("componentType") not in _COMPONENTS or a.get("type") not in _WIDTH:
        raise PeerError(f"accessor {index}: {a.get('type')} of component type {a.get('componentType')} is not read here")
    view = gltf["bufferViews"][a["bufferView"]]
    dtype = np.dtype(_COMPONENTS[a["componentType"]]).newbyteorder("<")
    width = _WIDTH[a["type"]]
    stride = view.get("byteStride", dtype.itemsize * width)
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    end = start + (stride * (a["count"] - 1) + dtype.itemsize * width if a["count"] else 0)
    if end > view.get("byteOffset", 0) + view["byteLength"] or end > len(binary):
        raise PeerError(f"accessor {index} runs past the end of its buffer view")
    values = np.ndarray((a["count"], width), dtype=dtype, buffer=binary, offset=start, strides=(stride, dtype.itemsize)).astype(np.float64)
    if a.get("normalized"):
        values = np.maximum(values / _NORMALIZED[a["componentType"]], -1.0)
    return values


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(node.get("scale", [1.0, 1.0, 1.0]))[None, :]
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def _world_matrix(gltf: dict, index: int) -> np.ndarray:
    parent = {c: i for i, n in enumerate(gltf.get("nodes", [])) for c in n.get("children", [])}
    m = np.eye(4)
    while index is not None:
        m = _node_matrix(gltf["nodes"][index]) @ m
        index = parent.get(index)
    return m


def _weights(gltf: dict, binary: bytes, node: int, targets: int, frames: int) -> np.ndarray:
    """The morph weights (frames, targets) the node's animation gives at t / TIMELINE_HZ."""
    for anim in gltf.get("animations", []):
        for ch in anim["channels"]:
            if ch["target"].get("node") == node and ch["target"]["path"] == "weights":
                s = anim["samplers"][ch["sampler"]]
                times = read_accessor(gltf, binary, s["input"])[:, 0]
                values = read_accessor(gltf, binary, s["output"]).reshape(len(times), -1)
                mode = s.get("interpolation", "LINEAR")
                at = np.arange(frames) / TIMELINE_HZ
                if mode == "STEP":
                    return values[np.clip(np.searchsorted(times, at + 1e-4, side="right") - 1, 0, len(times) - 1)]
                if mode == "LINEAR":
                    return np.stack([np.interp(at, times, values[:, k]) for k in range(targets)], axis=1)
                raise PeerError(f"weights animation with {mode} interpolation is not read here")
    raise PeerError("the packed file has no weights animation")


def read_morph_motion(gltf: dict, binary: bytes, frames: int):
    """The frames (F, V, 3) and faces of a morph-target glTF like `morph_glb`'s."""
    nodes = [i for i, n in enumerate(gltf.get("nodes", [])) if "mesh" in n]
    if len(nodes) != 1 or len(gltf["meshes"][gltf["nodes"][nodes[0]]["mesh"]]["primitives"]) != 1:
        raise PeerError("the packed file does not hold exactly one mesh with one primitive")
    prim = gltf["meshes"][gltf["nodes"][nodes[0]]["mesh"]]["primitives"][0]
    if "indices" not in prim or prim.get("mode", 4) != 4:
        raise PeerError("the packed mesh is not an indexed triangle list")
    base = read_accessor(gltf, binary, prim["attributes"]["POSITION"])
    targets = np.stack([read_accessor(gltf, binary, t["POSITION"]) for t in prim.get("targets", [])]) if prim.get("targets") else np.zeros((0,) + base.shape)
    w = _weights(gltf, binary, nodes[0], len(targets), frames)
    local = base[None] + np.einsum("fk,kvc->fvc", w, targets)
    m = _world_matrix(gltf, nodes[0])
    world = local @ m[:3, :3].T + m[:3, 3]
    faces = read_accessor(gltf, binary, prim["indices"]).astype(np.uint32).reshape(-1, 3)
    return world.astype(np.float32), faces


# ---------------------------------------------------------------- gltfpack


def _node_modules(path) -> pathlib.Path:
    p = pathlib.Path(path or os.environ.get("CGV_NODE_MODULES") or _CHECKOUT_MODULES)
    for need in ("gltfpack/cli.js", "meshoptimizer/meshopt_decoder.mjs"):
        if not (p / need).exists():
            raise PeerError(f"{p / need}: not found; give --node-modules a node_modules folder with gltfpack and meshoptimizer (npm install gltfpack meshoptimizer)")
    return p


def _run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise PeerError(f"{' '.join(map(str, cmd))} failed ({r.returncode}): {r.stderr.strip() or r.stdout.strip()}")
    return r.stdout


def gltfpack_curves(positions, faces, diagonal, bits=GLTFPACK_BITS, modes=GLTFPACK_MODES, surface_every=1, node_modules=None, node="node", progress=print):
    modules = _node_modules(node_modules)
    version = json.loads((modules / "gltfpack" / "package.json").read_text())["version"]
    frames, vertices, _ = positions.shape
    curves = []
    with tempfile.TemporaryDirectory(prefix="cgv-peers-") as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "in.glb").write_bytes(morph_glb(positions, faces))
        for mode in modes:
            points = []
            for b in bits:
                t0 = time.perf_counter()
                packed, plain = tmp / f"{mode}-{b}.glb", tmp / f"{mode}-{b}.gltf"
                _run([node, modules / "gltfpack" / "cli.js", "-i", tmp / "in.glb", "-o", packed, "-vp", str(b), f"-{mode}"])
                data = packed.read_bytes()
                size = len(gzip.compress(data, compresslevel=9, mtime=0))
                _run([node, _DECODE_JS, modules / "meshoptimizer" / "meshopt_decoder.mjs", packed, plain])
                decoded, decoded_faces = read_morph_motion(json.loads(plain.read_text()), (tmp / f"{plain.name}.bin").read_bytes(), frames)
                errors = measure(positions, faces, decoded, decoded_faces, diagonal, surface_every)
                points.append({**point(f"-vp {b}", size, frames, vertices, errors, time.perf_counter() - t0), "bytes_before_gzip": len(data)})
                progress(f"gltfpack -{mode} -vp {b}: {points[-1]['bits_per_input_vertex']:.2f} bits per vertex per frame")
            curves.append({"name": f"gltfpack -{mode}", "description": f"gltfpack {version} -vp B -{mode} on morph targets (frame 0 the base), then gzip -9", "points": points})
    return curves


# ---------------------------------------------------------------- the report


def run(path, *, frames=None, fps=30.0, animation=None, draco_bits=DRACO_BITS, gltfpack_bits=GLTFPACK_BITS, modes=GLTFPACK_MODES, surface_every=1, node_modules=None, node="node", progress=print) -> dict:
    """Measures the peers on a motion read as ``cgv eval`` reads it; the
    dict is what ``--json`` writes and ``cgv eval --peers`` reads."""
    positions, faces, fps = native.read_motion(str(path), fps=fps, frames=frames, animation=animation)
    if positions.shape[0] < 2:
        raise PeerError(f"{path}: morph targets need at least two frames")
    diagonal = native.diagonal(positions[0])
    if gltfpack_bits and modes:
        node_modules = _node_modules(node_modules)  # before the long Draco runs
    curves = []
    if draco_bits:
        curves.append(draco_curve(positions, faces, diagonal, draco_bits, surface_every, progress))
    if gltfpack_bits and modes:
        curves += gltfpack_curves(positions, faces, diagonal, gltfpack_bits, modes, surface_every, node_modules, node, progress)
    return {
        "input": str(path),
        "frames": int(positions.shape[0]),
        "fps": float(fps),
        "input_vertices": int(positions.shape[1]),
        "diagonal": float(diagonal),
        "first_frame_centroid": [float(x) for x in positions[0].astype(np.float64).mean(0)],
        "surface_every": surface_every,
        "normalization": "errors divided by the bounding-box diagonal of the first input frame; surface RMS the mean over "
        "measured frames of cgv's symmetric surface distance, max the largest; vertex errors on each input vertex's "
        "decoded vertex with the nearest trajectory",
        "curves": curves,
    }


def _ints(text):
    return tuple(int(x) for x in text.split(",") if x)


def _frames(text):
    a, sep, b = text.partition("..")
    if not sep or not a.isdigit() or not b.isdigit():
        raise argparse.ArgumentTypeError(f"{text!r}: frames are A..B (B excluded)")
    return int(a), int(b)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m cgv.peers", description=__doc__.split("\n\n")[0], epilog="See the module's documentation: python -c 'import cgv.peers; help(cgv.peers)'")
    ap.add_argument("input", help="a motion as cgv reads it: an OBJ folder, a glTF, builtin:walk")
    ap.add_argument("--frames", type=_frames, help="A..B, as in cgv eval (B excluded)")
    ap.add_argument("--fps", type=float, default=30.0, help="frame rate of an OBJ sequence (default 30)")
    ap.add_argument("--animation", help="the glTF animation to play (name or index)")
    ap.add_argument("--draco", type=_ints, default=DRACO_BITS, help=f"Draco quantization bits (default {','.join(map(str, DRACO_BITS))}; empty: none)")
    ap.add_argument("--gltfpack", type=_ints, default=GLTFPACK_BITS, help=f"gltfpack -vp bits (default {','.join(map(str, GLTFPACK_BITS))}; empty: none)")
    ap.add_argument("--modes", type=lambda s: tuple(x for x in s.split(",") if x), default=GLTFPACK_MODES, help="gltfpack compression modes (default cc,cz)")
    ap.add_argument("--surface-every", type=int, default=1, metavar="K", help="surface distance on every K-th frame, as cgv eval (0: never)")
    ap.add_argument("--node-modules", help="node_modules with gltfpack and meshoptimizer (default: $CGV_NODE_MODULES, else the checkout's tests/node/node_modules)")
    ap.add_argument("--node", default="node", help="the Node executable")
    ap.add_argument("--json", type=pathlib.Path, help="write the report here (default: stdout)")
    args = ap.parse_args(argv)
    try:
        report = run(args.input, frames=args.frames, fps=args.fps, animation=args.animation, draco_bits=args.draco, gltfpack_bits=args.gltfpack, modes=args.modes, surface_every=args.surface_every, node_modules=args.node_modules, node=args.node, progress=lambda m: print(m, file=sys.stderr))
    except (PeerError, native.Error) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    text = json.dumps(report, indent=2)
    if args.json:
        tmp = args.json.with_name(args.json.name + ".tmp")
        tmp.write_text(text)
        tmp.replace(args.json)
        print(f"wrote {args.json}", file=sys.stderr)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
