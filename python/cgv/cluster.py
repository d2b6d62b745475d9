"""Encode a library of motions as Ray tasks, one task per motion.

    python -m cgv.cluster JOBS.json        (pip install "./python[ray]")

or from Python: ``cgv.cluster.run(cgv.cluster.load("JOBS.json"))`` after
``ray.init()``.

JOBS.json lists the jobs, each with its input (anything `cgv encode` reads),
its output .cgv path and the keyword options of `cgv.encode_file` (named as
`cgv encode`'s flags, `_` for `-`)::

    [{"input": "captures/samba", "output": "out/samba.cgv", "options": {"grid": 256, "kbps": 600}},
     {"input": "captures/pcow",  "output": "out/pcow.cgv",  "options": {"frames": [0, 120]}}]

Relative paths are relative to the manifest's folder. As with
`cgv encode --manifest`, a job already done (its output reads as a .cgv file
and the sidecar OUTPUT.job beside it records the same job) is skipped,
outputs are written atomically (a temporary file renamed), a failed job is
reported without stopping the others, and the encoder is deterministic: a
task gives the bytes `cgv encode` gives for the same input and options.

Where it runs: `ray.init()` connects to the cluster named by RAY_ADDRESS, or
starts a local one on this machine when there is none. On a real cluster,
start Ray on the machines (`ray start --head` on one, `ray start
--address=HEAD:6379` on the others), install this package on every node
(`pip install ./python` from a checkout, or the wheel CI builds), put the
inputs and outputs on storage every node sees (NFS, a mounted bucket), and
submit the same command: `ray job submit --address http://HEAD:8265 --
python -m cgv.cluster /shared/jobs.json`. Ray schedules the tasks; there is
no scheduler of ours.
"""

import json
import os
import pathlib
import sys

import ray

import cgv

__all__ = ["encode_job", "is_done", "load", "run"]


def _job_text(job):
    return json.dumps({"input": job["input"], "options": job.get("options", {})}, sort_keys=True)


def is_done(job):
    """Whether the job's output is a whole .cgv file made by this very job."""
    out = pathlib.Path(job["output"])
    sidecar = out.with_name(out.name + ".job")
    try:
        if sidecar.read_text() != _job_text(job):
            return False
        cgv.info(out.read_bytes())
        return True
    except (OSError, cgv.Error):
        return False


def _write_atomic(path, data):
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    tmp.write_bytes(data)
    os.replace(tmp, path)


@ray.remote
def encode_job(job):
    """One motion: encodes it, writes the output and its sidecar, returns (output, bytes)."""
    options = dict(job.get("options", {}))
    if "output" in options:
        raise ValueError(f"{job['input']}: the job's output is its own field, not an option")
    if "frames" in options:
        options["frames"] = tuple(options["frames"])
    pathlib.Path(job["output"]).parent.mkdir(parents=True, exist_ok=True)
    # Streamed into the output as it is coded, written atomically.
    size = cgv.encode_file(job["input"], output=job["output"], **options)
    _write_atomic(job["output"] + ".job", _job_text(job).encode())
    return job["output"], size


def load(manifest):
    """The jobs of a manifest file, their paths made relative to its folder."""
    base = pathlib.Path(manifest).resolve().parent
    jobs = json.loads(pathlib.Path(manifest).read_text())
    for job in jobs:
        if not str(job["input"]).startswith("builtin:"):
            job["input"] = str(base / job["input"])
        job["output"] = str(base / job["output"])
    return jobs


def run(jobs):
    """Encodes every job not done yet as a Ray task; returns (encoded, skipped, failed)."""
    todo = [j for j in jobs if not is_done(j)]
    skipped = len(jobs) - len(todo)
    pending = {encode_job.remote(j): j for j in todo}
    encoded, failed = [], []
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        job = pending.pop(ready[0])
        try:
            output, size = ray.get(ready[0])
            encoded.append(output)
            print(f"{output}: {size} bytes", flush=True)
        except Exception as e:  # a task's error comes back wrapped; report it, go on
            failed.append((job["output"], str(getattr(e, "cause", e))))
            print(f"{job['output']}: failed: {failed[-1][1]}", file=sys.stderr, flush=True)
    return encoded, skipped, failed


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    ray.init()
    encoded, skipped, failed = run(load(argv[1]))
    print(f"{len(encoded) + skipped + len(failed)} jobs: {len(encoded)} encoded, {skipped} skipped, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
