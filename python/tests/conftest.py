"""Shared fixtures: the CLI binary and the shared sequences, unpacked once per run."""

import os
import pathlib
import tarfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def cgv_bin():
    """The `cgv` CLI built from this checkout (CGV_BIN, else the release build)."""
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    path = pathlib.Path(os.environ.get("CGV_BIN", pathlib.Path(target) / "release" / "cgv"))
    assert path.exists(), f"{path}: build the CLI first (cargo build --release) or set CGV_BIN"
    return str(path)


@pytest.fixture(scope="session")
def sequences(tmp_path_factory):
    """Every sequence in ../shared/data, unpacked into a temporary folder: name -> folder of OBJ files."""
    archives = sorted(SHARED.glob("*.tar.xz"))
    assert archives, f"{SHARED}: no sequences (the tests need ../shared beside the checkout)"
    dest = tmp_path_factory.mktemp("sequences")
    out = {}
    for a in archives:
        name = a.name[: -len(".tar.xz")]
        with tarfile.open(a) as t:
            t.extractall(dest / name, filter="data")
        folder = dest / name / name
        out[name] = folder if folder.is_dir() else next((dest / name).iterdir())
    return out
