"""pybullet's math library, the same on every x86-64 CPU.

pybullet's physics calls glibc's ``sin``, ``cos``, ``atan2``, ``acos``, ``exp``, ``pow`` and their kin, and glibc
picks one of several builds of each when a process starts, by the CPU's features: an FMA build on CPUs with FMA
and AVX2 (Intel since 2013, AMD since 2015), an FMA4 build on older AMD, a plain SSE2 build on older CPUs and on
virtual machines that hide those features. The builds differ in the last bit for about one argument in a
thousand (measured: 286 of 400,000 sines), and a simulated grasp turns one bit into another slip now and then:
the same job gave 2 of 423 grasps a different ``slip`` on a node that took the SSE2 build.

So every process that simulates starts with glibc's ``glibc.cpu.hwcaps`` tunable masking AVX, AVX2, FMA and FMA4,
and takes the SSE2 build whatever its CPU. The mask is read by the dynamic loader when a process starts, so it is
given to processes as they start: the ``onepiece`` command and the test suite start themselves again with it
(:func:`restart_pinned`), Ray's workers get it in their runtime environment and from the process that started
their node (:func:`pin_children`), and an in-process job in a process started without it simulates in a child
process that has it. It changes which build of glibc's functions runs (its string functions too), nothing in
numpy, OpenBLAS or torch: they pick their own kernels, and the package's results do not depend on them
(tests/test_pinned_job.py).

Elsewhere nothing needs pinning: aarch64's glibc has one build of each function, and other systems are not
supported for simulation. Two machines agree when they run the same glibc release and the same pybullet wheel.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping

TUNABLES = "GLIBC_TUNABLES"
HWCAPS = "glibc.cpu.hwcaps"
MASKED = ("-AVX", "-AVX2", "-FMA", "-FMA4")  # what glibc's x86-64 math functions choose their build by
RESTARTED = "ONEPIECE_LIBM_RESTARTED"  # set on a process this module started again: it never restarts twice


def pinning_needed() -> bool:
    """Whether this machine's glibc picks a math-function build per CPU (x86-64 Linux with glibc)."""
    return (sys.platform == "linux" and platform.machine() in ("x86_64", "AMD64")
            and platform.libc_ver()[0] == "glibc")


def pinned_tunables(current: str | None) -> str:
    """A ``GLIBC_TUNABLES`` value: ``current``'s tunables with :data:`MASKED` added to its hwcaps mask (made when
    missing). Tunables are ``name=value`` entries joined by colons; the hwcaps value is comma-separated."""
    entries = [entry for entry in (current or "").split(":") if entry]
    hwcaps = [entry for entry in entries if entry.startswith(f"{HWCAPS}=")]
    masks = [mask for entry in hwcaps for mask in entry.split("=", 1)[1].split(",") if mask]
    masks += [mask for mask in MASKED if mask not in masks]
    others = [entry for entry in entries if not entry.startswith(f"{HWCAPS}=")]
    return ":".join([*others, f"{HWCAPS}={','.join(masks)}"])


def pinned_environment(environment: Mapping[str, str]) -> dict[str, str]:
    """``environment`` with the hwcaps mask in its ``GLIBC_TUNABLES`` (unchanged where no pinning is needed)."""
    if not pinning_needed():
        return dict(environment)
    return {**environment, TUNABLES: pinned_tunables(environment.get(TUNABLES))}


def worker_environment() -> dict[str, str]:
    """Environment variables every worker process is started with (Ray's runtime environment ``env_vars``)."""
    return {TUNABLES: pinned_tunables(None)} if pinning_needed() else {}


def _masks_of(tunables: str | None) -> set[str]:
    return {mask for entry in (tunables or "").split(":") if entry.startswith(f"{HWCAPS}=")
            for mask in entry.split("=", 1)[1].split(",")}


def startup_environment() -> dict[str, str]:
    """The environment this process was started with (what the dynamic loader read), not ``os.environ`` now."""
    try:
        raw = open("/proc/self/environ", "rb").read()  # noqa: SIM115 - a one-shot read of a kernel file
    except OSError:
        return dict(os.environ)
    pairs = (item.split(b"=", 1) for item in raw.split(b"\0") if b"=" in item)
    return {key.decode(errors="replace"): value.decode(errors="replace") for key, value in pairs}


def libm_pinned() -> bool:
    """Whether this process runs glibc's SSE2 math functions on every CPU: it started with the mask, or the
    machine needs none."""
    return not pinning_needed() or set(MASKED) <= _masks_of(startup_environment().get(TUNABLES))


def pin_children() -> None:
    """Put the mask into this process's environment, so every process it starts from now on (a Ray node, a
    child that simulates) has it. This process itself keeps the build it started with."""
    if pinning_needed():
        os.environ[TUNABLES] = pinned_tunables(os.environ.get(TUNABLES))


def restart_pinned() -> None:
    """Start this process again with the mask (the same interpreter and arguments), unless it has it already,
    needs none, or was started again once before. Call it first thing, before any output or thread."""
    if libm_pinned() or os.environ.get(RESTARTED):
        return
    sys.stdout.flush()
    sys.stderr.flush()
    environment = {**pinned_environment(os.environ), RESTARTED: "1"}
    os.execve(sys.executable, [sys.executable, *sys.orig_argv[1:]], environment)
