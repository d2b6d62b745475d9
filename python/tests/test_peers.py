"""cgv.peers: Draco and gltfpack measured as `cgv eval` measures us, and `cgv eval --peers`."""

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import cgv
from cgv import peers

MODULES = pathlib.Path(__file__).resolve().parents[2] / "tests" / "node" / "node_modules"


@pytest.fixture(scope="module")
def walk():
    return cgv.read_motion("builtin:walk", frames=(0, 4))


def test_our_morph_glb_reads_back_exactly(walk):
    """The writer and the reader of morph-target files agree (what the gltfpack figures rest on)."""
    positions, faces, _ = walk
    glb = peers.morph_glb(positions, faces)
    n = int.from_bytes(glb[12:16], "little")
    gltf = json.loads(glb[20 : 20 + n])
    binary = glb[20 + n + 8 :]
    frames, back_faces = peers.read_morph_motion(gltf, binary, positions.shape[0])
    assert np.array_equal(back_faces, faces)
    assert np.abs(frames - positions).max() < 1e-6 * cgv.diagonal(positions)


def test_trajectory_matching_undoes_a_shuffle(walk):
    positions = walk[0]
    order = np.random.default_rng(1).permutation(positions.shape[1])
    shuffled = positions[:, order]
    match = peers.match_trajectories(positions, shuffled)
    assert np.array_equal(shuffled[:, match], positions)


def test_draco_error_is_its_quantization(walk):
    positions, faces, _ = walk
    diag = cgv.diagonal(positions[0])
    curve = peers.draco_curve(positions, faces, diag, bits=(8, 12), progress=lambda m: None)
    coarse, fine = curve["points"]
    assert coarse["bytes"] < fine["bytes"] and fine["vertex_rms"] < coarse["vertex_rms"] / 8
    # Draco rounds to 2^q - 1 steps over the largest extent of each frame:
    # a uniform error of RMS step / 2 per vertex (step / sqrt(12) per axis).
    extent = max((positions[t].max(0) - positions[t].min(0)).max() for t in range(positions.shape[0]))
    for p, q in ((coarse, 8), (fine, 12)):
        model = extent / (2**q - 1) / 2 / diag
        assert 0.8 * model < p["vertex_rms"] < 1.2 * model, (q, p["vertex_rms"], model)
        assert 0.2 < p["surface_rms"] / p["vertex_rms"] < 0.8


@pytest.mark.skipif(not (MODULES / "gltfpack").is_dir(), reason="tests/node has no gltfpack (pkg-scripts/setup.sh installs it)")
def test_gltfpack_is_decoded_for_real(walk):
    positions, faces, _ = walk
    diag = cgv.diagonal(positions[0])
    curves = peers.gltfpack_curves(positions, faces, diag, bits=(8, 12), modes=("cc",), node_modules=MODULES, progress=lambda m: None)
    (curve,) = curves
    coarse, fine = curve["points"]
    assert curve["name"] == "gltfpack -cc" and coarse["bytes"] < fine["bytes"]
    # -vp B: B bits over the base mesh's largest extent padded on each side
    # by the largest offset of a target (gltfpack's range), rounded twice
    # (the base mesh, then each target's offset from it): at most one step
    # per axis. A frame decoded at the wrong time would be far off.
    deltas = np.abs(positions[1:] - positions[0]).max()
    extent = (positions[0].max(0) - positions[0].min(0)).max() + 2 * deltas
    for p, b in ((coarse, 8), (fine, 12)):
        bound = extent / (2**b - 1) * np.sqrt(3) / diag
        assert p["vertex_max"] <= bound * 1.01, (b, p["vertex_max"], bound)
        assert p["vertex_rms"] > bound / 20, "an error far below the quantization: not what gltfpack wrote"


@pytest.mark.skipif(not (MODULES / "gltfpack").is_dir(), reason="tests/node has no gltfpack (pkg-scripts/setup.sh installs it)")
def test_cgv_eval_puts_the_peers_on_its_chart(cgv_bin, tmp_path):
    out = tmp_path / "peers.json"
    subprocess.run(
        [sys.executable, "-m", "cgv.peers", "builtin:walk", "--frames", "0..4", "--draco", "8,10", "--gltfpack", "8,10", "--modes", "cc",
         "--node-modules", str(MODULES), "--json", str(out)],
        check=True, capture_output=True,
    )
    report = json.loads(out.read_text())
    assert [c["name"] for c in report["curves"]] == ["draco", "gltfpack -cc"]
    md = tmp_path / "walk.md"
    subprocess.run(
        [cgv_bin, "eval", "builtin:walk", "--frames", "0..4", "--grid", "32", "--codecs", "predictive", "--kbps", "200,800",
         "--peers", str(out), "--md", str(md), "--json", str(tmp_path / "walk.json"), "--plot", str(tmp_path / "walk.svg")],
        check=True, capture_output=True,
    )
    text = md.read_text()
    assert "## Against what users ship" in text and "| gltfpack -cc | -vp 10 |" in text
    joined = json.loads((tmp_path / "walk.json").read_text())["peers"]
    assert len(joined["comparisons"]) == 4 and joined["codec"] == "predictive"
    assert "gltfpack -cc" in (tmp_path / "walk.svg").read_text()
    # Made on other frames: refused before the run, naming the file.
    r = subprocess.run([cgv_bin, "eval", "builtin:walk", "--frames", "0..5", "--grid", "32", "--peers", str(out)], capture_output=True, text=True)
    assert r.returncode != 0 and "peers.json" in r.stderr and "4 frames where the evaluation has 5" in r.stderr
