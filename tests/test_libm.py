"""glibc's math functions pinned to one build in every process that simulates (onepiece_dist.sim.libm): a job's
physics must not depend on whether a node's CPU has FMA."""

from __future__ import annotations

import hashlib
import math
import os
import random
import subprocess
import sys

import pytest

from onepiece_dist.sim.libm import (
    MASKED,
    RESTARTED,
    TUNABLES,
    libm_pinned,
    pinned_environment,
    pinned_tunables,
    pinning_needed,
    worker_environment,
)

pytestmark = pytest.mark.skipif(not pinning_needed(), reason="only x86-64 glibc picks a math build per CPU")

OLDEST_CPU_GLIBC = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX"  # what a node of tests/test_resume_and_cluster.py starts with
PROBE = "from tests.test_libm import libm_bits; print(libm_bits())"  # run in the checkout's root: tests imports
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def libm_bits(count: int = 20_000) -> str:
    """Digest of the bits of glibc's sin, cos, atan2, acos and exp (Python's math module calls them, as
    pybullet does) on ``count`` seeded arguments each: FMA and SSE2 builds differ on about one in a thousand."""
    rng = random.Random(7)
    digest = hashlib.blake2b(digest_size=8)
    for _ in range(count):
        x, y = rng.uniform(-4, 4), rng.uniform(-1, 1)
        for value in (math.sin(x), math.cos(x), math.atan2(y, x), math.acos(y), math.exp(x)):
            digest.update(value.hex().encode())
    return digest.hexdigest()


def bits_in_process(environment: dict[str, str]) -> str:
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=environment, cwd=ROOT,
                         timeout=120, check=True)
    return out.stdout.strip()


def unpinned(environment: dict[str, str]) -> dict[str, str]:
    return {k: v for k, v in environment.items() if k not in (TUNABLES, RESTARTED)}


def cpu_has_fma() -> bool:
    with open("/proc/cpuinfo") as info:
        flags = next((line.split(":", 1)[1].split() for line in info if line.startswith("flags")), [])
    return "fma" in flags and "avx2" in flags


def test_the_mask_joins_the_tunables_a_process_already_has():
    assert pinned_tunables(None) == "glibc.cpu.hwcaps=" + ",".join(MASKED)
    merged = pinned_tunables("glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX512F,-FMA")
    assert merged == "glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX512F,-FMA,-AVX,-AVX2,-FMA4"
    assert pinned_tunables(merged) == merged
    assert pinned_environment({"HOME": "/x"}) == {"HOME": "/x", TUNABLES: pinned_tunables(None)}
    assert worker_environment() == {TUNABLES: pinned_tunables(None)}


def test_the_suite_runs_pinned_and_computes_as_the_oldest_cpu():
    """The test process was started again with the mask (tests/pinned_libm.py) and takes the same math build as
    a process forced onto an older CPU's; on a CPU with FMA, a process without the mask takes another one."""
    assert libm_pinned()
    older = bits_in_process({**unpinned(os.environ), TUNABLES: OLDEST_CPU_GLIBC})
    assert libm_bits() == older
    if cpu_has_fma():
        assert bits_in_process(unpinned(os.environ)) != older, "the probe does not tell the builds apart"


@pytest.mark.ray
@pytest.mark.slow
def test_an_actor_computes_as_the_oldest_cpu_even_on_a_node_started_without_the_mask():
    """Ray's workers take the mask from the actor's runtime environment, not from the node that starts them: a
    Ray started from a process without the mask still runs our actors pinned."""
    script = """
import ray
from onepiece_dist.runtime.actors import restartable_actor
from tests.test_libm import libm_bits
class Probe:
    def bits(self):
        return libm_bits()
ray.init(address="local", num_cpus=1, include_dashboard=False, log_to_driver=False)
actor = restartable_actor(Probe, "libm-probe", num_cpus=1).remote()
print(ray.get(actor.bits.remote()))
"""
    environment = {**unpinned(os.environ), "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=ROOT,
                         timeout=240)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().splitlines()[-1] == bits_in_process({**unpinned(os.environ), TUNABLES: OLDEST_CPU_GLIBC})


@pytest.mark.sim
@pytest.mark.slow
def test_a_job_run_in_process_from_an_unpinned_process_gives_the_pinned_dataset(tmp_path, fault_free):
    """A script that runs a job in process without the mask (the Python API in a notebook) simulates in a pinned
    child: its dataset is the one the pinned suite makes, bit for bit, on a job where the two builds give
    different slips."""
    from onepiece_dist.store.dataset import content_digest
    from tests.test_pinned_job import pinned_spec

    spec = pinned_spec(tmp_path / "pinned.zarr").model_copy(update={"objects": DIFFERS_BY_BUILD})
    script = ("from tests.test_pinned_job import pinned_spec; "
              "from onepiece_dist.runtime.local import run_local; from pathlib import Path; "
              f"run_local(pinned_spec(Path({str(tmp_path / 'unpinned.zarr')!r})).model_copy("
              f"update={{'objects': {DIFFERS_BY_BUILD!r}}}))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=unpinned(os.environ),
                         cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert content_digest(tmp_path / "unpinned.zarr", training=False) == content_digest(fault_free(spec),
                                                                                         training=False)


DIFFERS_BY_BUILD = "pybullet:named[3:4]+pybullet:random_urdfs[0:5]"  # 2 of its 423 slips differ between builds
