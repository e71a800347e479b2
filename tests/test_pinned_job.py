"""A small labelled job's codes and labels, pinned: speed work must not change what a job produces.

The pins (tests/data/pinned_job.json) hold a digest of each array that is a code, a label, or decides which grasp
stands for which code, for one fixed spec run in process. A change of physics, sampling or voxelization on purpose
changes them: rerun ``python tests/test_pinned_job.py --write`` and say why in the commit. Floats that only
describe geometry (points, poses) are not pinned: their last bits may move with a faster but equal formula.

First written at c7cfa8b, where the same pins held at 3ce0724 (the code before the assembly, clip and label-shard
speed work of 278afbc..c7cfa8b). Those pins held only on CPUs whose BLAS kernel gave the patches the same last bits:
on another machine (AMD EPYC, AVX2) the one object's codes differed, and forcing OpenBLAS's SSE kernel changed its
labels. Patch geometry is now rotated without BLAS (``core.frames.rotate_points``), the pins were written again,
and the second test runs the job under another BLAS kernel and asks for the same pins.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import zarr

PINS = Path(__file__).parent / "data" / "pinned_job.json"
PINNED_ARRAYS = ("grasps/code", "grasps/candidate_code", "grasps/object", "unique/code", "unique/count",
                 "unique/representative", "assembled/plane", "assembled/grasps/code", "assembled/grasps/patch",
                 "assembled/grasps/success", "assembled/grasps/quality")


def pinned_spec(output: Path):
    from onepiece_dist.spec import JobSpec

    return JobSpec(objects="pybullet:named[3:4]+pybullet:random_urdfs[0:2]", grasps_per_object=24,
                   output=str(output), stages=("ingest", "extract", "dedup", "assemble", "label"))


def array_pins(path: Path) -> dict[str, str]:
    """{array path: "dtype shape blake2b-hex"} of every pinned array of the dataset at ``path``."""
    root = zarr.open_group(str(path), mode="r")
    pins = {}
    for name in PINNED_ARRAYS:
        values = np.ascontiguousarray(root[name][...])
        digest = hashlib.blake2b(values.tobytes(), digest_size=12).hexdigest()
        pins[name] = f"{values.dtype} {list(values.shape)} {digest}"
    return pins


def run_pinned_job(folder: Path) -> dict[str, str]:
    from onepiece_dist.service.local import run_local

    output = folder / "pinned.zarr"
    run_local(pinned_spec(output))
    return array_pins(output)


@pytest.mark.sim
@pytest.mark.slow
def test_a_small_jobs_codes_and_labels_are_the_pinned_ones(tmp_path):
    expected = json.loads(PINS.read_text())["arrays"]
    found = run_pinned_job(tmp_path)
    changed = {name: (expected[name], found[name]) for name in PINNED_ARRAYS if expected[name] != found[name]}
    assert not changed, f"these arrays changed (pinned, found): {changed}; {__doc__}"


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS's SSE kernel (Prescott) is an x86-64 one")
def test_the_pins_hold_under_another_blas_kernel():
    """The same job with OpenBLAS forced to its SSE kernel (every x86-64 CPU runs it; machines pick AVX2 or
    AVX-512 ones by themselves): what a worker produces must not depend on the CPU it ran on."""
    env = {**os.environ, "OPENBLAS_CORETYPE": "Prescott"}
    out = subprocess.run([sys.executable, __file__, "--print"], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    expected, found = json.loads(PINS.read_text())["arrays"], json.loads(out.stdout.splitlines()[-1])
    assert {name: found[name] for name in PINNED_ARRAYS if expected[name] != found[name]} == {}


if __name__ == "__main__" and sys.argv[1:] == ["--print"]:
    import tempfile

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    with tempfile.TemporaryDirectory() as scratch:
        print(json.dumps(run_pinned_job(Path(scratch))))

if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        pins = run_pinned_job(Path(scratch))
    spec = pinned_spec(Path("pinned.zarr")).model_dump(mode="json", exclude={"output"})
    PINS.write_text(json.dumps({"spec": spec, "arrays": pins}, indent=1) + "\n")
    print(f"wrote {PINS}")
