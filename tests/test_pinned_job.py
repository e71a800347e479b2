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

On an AVX-512 Sapphire Rapids machine the pins still differed in ``assembled/grasps/code`` under every numpy, BLAS
and glibc setting: the antipodal sampler took its candidates' centres and widths from Embree's float32 ray casts,
whose kernel Embree picks for the CPU by itself. Ray hits are now computed again in float64 (``core.raycast``),
the pins were written again, and the job runs under every CPU setting this machine offers (CPU_SETTINGS): BLAS
kernels, numpy's CPU features, glibc's hwcaps, one and two threads on one CPU and two. ``--write`` writes the pins
only when every setting gives the same ones; the test runs the older CPU's three paths at once (cpu_settings).
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
    from onepiece_dist.specs.job import JobSpec

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
    from onepiece_dist.runtime.local import run_local

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


def cpu_flags() -> set[str]:
    """This CPU's feature flags as /proc/cpuinfo names them (empty where it cannot be read)."""
    info = Path("/proc/cpuinfo")
    lines = info.read_text().splitlines() if info.is_file() else []
    return set(next((line.split(":", 1)[1].split() for line in lines if line.startswith("flags")), []))


def cpu_settings() -> dict[str, dict[str, str]]:
    """{name: environment} of the CPU paths this machine can be made to take besides its own, each set in a fresh
    process before numpy, OpenBLAS, glibc's libm, open3d and pybullet load. "one CPU" also pins the process to one
    core, so Embree's and TBB's thread pools have one thread. "two threads" is left out where this process has two
    cores: there it is the default, which the first test runs. An older x86-64 CPU takes all three of its paths at
    once (OpenBLAS's SSE kernel, numpy without AVX2 or AVX-512, glibc without AVX, AVX2 or FMA), so they are set
    together, as on the older-CPU node of tests/test_resume_and_cluster.py; where that setting fails, `--write`
    names which of them moved the pins (OLDER_CPU_PATHS, one at a time)."""
    settings = {"one thread, one CPU": {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", ONE_CPU: "1"}}
    if len(os.sched_getaffinity(0)) != 2:
        settings["two threads"] = {"OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}
    if platform.machine() != "x86_64":
        return settings
    flags = cpu_flags()
    settings["an older CPU: SSE BLAS, numpy and glibc without AVX"] = {
        key: value for path in OLDER_CPU_PATHS.values() for key, value in path.items()}
    if "avx512f" in flags:
        settings["OpenBLAS AVX-512 kernel"] = {"OPENBLAS_CORETYPE": "SkylakeX"}
    if "avx2" in flags:
        settings["OpenBLAS AVX2 kernel"] = {"OPENBLAS_CORETYPE": "Haswell"}
    return settings


OLDER_CPU_PATHS = {"OpenBLAS SSE kernel": {"OPENBLAS_CORETYPE": "Prescott"},
                   "numpy without AVX2 or AVX-512": {"NPY_DISABLE_CPU_FEATURES": "X86_V3"},
                   "glibc without AVX, AVX2, FMA": {"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX"}}
ONE_CPU = "ONEPIECE_TEST_ONE_CPU"  # read by this file's --print only, to pin itself to one core


def pins_under(env: dict[str, str]) -> dict[str, str]:
    """The pinned job's pins from a fresh process with ``env`` added to this one's environment."""
    out = subprocess.run([sys.executable, __file__, "--print"], capture_output=True, text=True,
                         env={**os.environ, **env}, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.parametrize("setting", sorted(cpu_settings()))
def test_the_pins_hold_under_every_cpu_setting(setting):
    """The same job with one of this machine's other CPU paths forced (machines pick their own by themselves):
    what a worker produces must not depend on the CPU it ran on."""
    expected, found = json.loads(PINS.read_text())["arrays"], pins_under(cpu_settings()[setting])
    assert {name: found[name] for name in PINNED_ARRAYS if expected[name] != found[name]} == {}


def every_setting() -> dict[str, dict[str, str]]:
    """The settings the test runs, and the older CPU's paths one at a time (for ``--write``)."""
    return {**cpu_settings(), **(OLDER_CPU_PATHS if platform.machine() == "x86_64" else {})}


if __name__ == "__main__" and sys.argv[1:] == ["--print"]:
    import tempfile

    if os.environ.get(ONE_CPU):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    with tempfile.TemporaryDirectory() as scratch:
        print(json.dumps(run_pinned_job(Path(scratch))))

if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        pins = run_pinned_job(Path(scratch))
    differ = {name: sorted(k for k in pins if pins[k] != found[k])
              for name, found in ((name, pins_under(env)) for name, env in every_setting().items())}
    if any(differ.values()):
        sys.exit(f"not written: the pins depend on the CPU path: {differ}")
    spec = pinned_spec(Path("pinned.zarr")).model_dump(mode="json", exclude={"output"})
    PINS.write_text(json.dumps({"spec": spec, "arrays": pins}, indent=1) + "\n")
    print(f"wrote {PINS}")
