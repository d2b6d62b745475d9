"""A library encoded as Ray tasks on a local cluster gives the CLI's bytes, skips what is done, reports failures."""

import json
import os
import subprocess

import pytest

import cgv

if os.environ.get("CGV_REQUIRE_RAY"):
    # pkg-scripts/test.sh installs Ray and sets this: there a missing Ray fails the run instead of skipping.
    import ray

    import cgv.cluster as cluster
else:
    ray = pytest.importorskip("ray", reason="Ray is installed by pkg-scripts/setup.sh; without it this test cannot run")
    cluster = pytest.importorskip("cgv.cluster")

# Small runs: three frames of every shared sequence on a 32 x 32 grid.
OPTIONS = {"grid": 32, "qp": 30, "frames": [0, 3]}


@pytest.fixture(scope="module")
def local_cluster():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_run_over_the_shared_sequences_gives_the_cli_bytes(local_cluster, sequences, cgv_bin, tmp_path):
    jobs = [{"input": str(folder), "output": str(tmp_path / f"{name}.cgv"), "options": OPTIONS}
            for name, folder in sorted(sequences.items())]
    jobs.append({"input": str(tmp_path / "missing"), "output": str(tmp_path / "missing.cgv"), "options": OPTIONS})
    manifest = tmp_path / "jobs.json"
    manifest.write_text(json.dumps(jobs))
    encoded, skipped, failed = cluster.run(cluster.load(manifest))
    assert len(encoded) == len(sequences) and skipped == 0
    assert [f[0] for f in failed] == [str(tmp_path / "missing.cgv")] and "missing" in failed[0][1]
    assert not (tmp_path / "missing.cgv").exists()
    for name, folder in sequences.items():
        cli = tmp_path / f"{name}-cli.cgv"
        subprocess.run([cgv_bin, "encode", str(folder), "--grid", "32", "--qp", "30", "--frames", "0..3",
                        "-o", str(cli)], check=True, capture_output=True)
        assert (tmp_path / f"{name}.cgv").read_bytes() == cli.read_bytes(), f"{name}: Ray and the CLI differ"
        assert cgv.info(cli.read_bytes())["header"]["frames"] == 3
    # Run again: every done job is skipped; a changed job is done again.
    again = cluster.load(manifest)
    again[0]["options"] = dict(OPTIONS, qp=34)
    encoded, skipped, failed = cluster.run(again)
    assert len(encoded) == 1 and skipped == len(sequences) - 1 and len(failed) == 1
