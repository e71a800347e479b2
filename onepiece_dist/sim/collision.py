"""Collision geometry for dynamic objects: a convex decomposition, computed once per object content id and
cached as an OBJ of convex pieces; the plain convex hull only when asked (with a warning).

Two decompositions: pybullet's VHACD (the default) and CoACD (collision-aware, Wei et al. 2022; the registry
package ``coacd``, extra ``decompose``), which cuts along concave features instead of voxelizing. Both run in a
child process: they crash on some meshes, and a crash there must not take the worker down. VHACD's child serves a
process's every object (:class:`VhacdChild`: starting Python and pybullet again for each cost as much as VHACD
itself on the objects of a job); a crash or a timeout ends it, and the next object starts another.
docs/decomposition.md measures them side by side (benchmarks/experiments/decomposition.py).
"""

from __future__ import annotations

import atexit
import json
import os
import select
import subprocess
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from onepiece_dist.core.mesh import TriangleMesh, enclosed_volume
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.meshio import parse_obj, write_obj

if TYPE_CHECKING:
    from onepiece_dist.objects import LoadedObject

# One request per line (a JSON list: SOURCE, TMP, RESOLUTION), one reply line each, on the stdout the child
# kept for replies: VHACD prints its progress to file descriptor 1, which the child points at /dev/null.
_VHACD_SCRIPT = """
import json, os, sys, pybullet as p
replies = os.fdopen(os.dup(1), "w")
os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
p.connect(p.DIRECT)
for line in sys.stdin:
    source, out, resolution = json.loads(line)
    p.vhacd(source, out, os.devnull, resolution=resolution, maxNumVerticesPerCH=32)
    replies.write("done\\n")
    replies.flush()
"""
# CoACD in one thread with a fixed seed: its pieces are the same on every run (threads would race its search).
_COACD_SCRIPT = """
import os, sys
os.environ["OMP_NUM_THREADS"] = "1"
import coacd, numpy as np
coacd.set_log_level("error")
data = np.load(sys.argv[1], allow_pickle=False)
parts = coacd.run_coacd(coacd.Mesh(data["vertices"], data["faces"]), threshold=float(sys.argv[3]), seed=0)
offset = 0
with open(sys.argv[2], "w") as out:
    for k, (vertices, faces) in enumerate(parts):
        out.write(f"o piece{k}\\n" + "".join(f"v {x!r} {y!r} {z!r}\\n" for x, y, z in vertices.tolist()))
        out.write("".join(f"f {a} {b} {c}\\n" for a, b, c in (faces + offset + 1).tolist()))
        offset += len(vertices)
"""
COACD_THRESHOLD = 0.05  # CoACD's concavity threshold (its default): lower cuts finer and runs longer


def user_decompositions() -> Path:
    """This user's folder of decompositions on this machine, which local jobs share (JobSpec.decompositions):
    ``$XDG_CACHE_HOME`` (default ``~/.cache``) ``/onepiece/decompositions/``, one folder per version of the
    decomposers (pybullet's VHACD, CoACD), since a new one may cut the same mesh otherwise. Owner-only."""
    from importlib.metadata import PackageNotFoundError, version

    def of(package: str) -> str:
        try:
            return f"{package}-{version(package)}"
        except PackageNotFoundError:
            return f"{package}-none"

    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = cache / "onepiece" / "decompositions" / f"{of('pybullet')}_{of('coacd')}"
    folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    return folder


def load_simulated(world, loaded: LoadedObject, cache_dir: Path, method: str, default_density: float) -> None:
    """``loaded`` as ``world``'s object: its convex pieces by ``method`` (cached in ``cache_dir``), the mass of its
    enclosed volume at its manifest's density or mass (else ``default_density``), its own friction."""
    volume = enclosed_volume(loaded.mesh)
    world.load_object(convex_pieces(loaded.mesh, cache_dir, method), volume, loaded.density(default_density, volume),
                      loaded.friction)


def convex_pieces(mesh: TriangleMesh, cache_dir: Path, method: str = "vhacd",
                  resolution: int = 50_000, threshold: float = COACD_THRESHOLD) -> list[np.ndarray]:
    """Convex pieces of ``mesh`` as a list of (k, 3) float64 vertex arrays (each the hull of its points), by
    ``method`` vhacd (at ``resolution`` voxels), coacd (at concavity ``threshold``) or hull."""
    if method == "hull":
        warnings.warn(f"{mesh.name}: collision geometry is the convex hull; grasps on concave parts are distorted",
                      stacklevel=2)
        return [mesh.vertices]
    cache_dir.mkdir(parents=True, exist_ok=True)
    if method == "coacd":
        out = cache_dir / f"{mesh.content_id}-coacd{threshold:g}.obj"
        pieces = _cached_or_made(out, mesh.name, lambda: _run_coacd(mesh, cache_dir, out, threshold))
        if pieces is not None:
            return pieces
        warnings.warn(f"{mesh.name}: CoACD failed (is the 'coacd' package installed? pip install "
                      "'onepiece-dist[decompose]'); using VHACD", stacklevel=2)
    out = cache_dir / f"{mesh.content_id}-vhacd{resolution}.obj"
    pieces = _cached_or_made(out, mesh.name, lambda: _run_vhacd(mesh, cache_dir, out, resolution))
    if pieces is None:
        warnings.warn(f"{mesh.name}: convex decomposition failed; using the convex hull", stacklevel=2)
        return [mesh.vertices]
    return pieces


def _cached_or_made(out: Path, name: str, make: Callable[[], None]) -> list[np.ndarray] | None:
    """The pieces in ``out`` (a decomposition made earlier, maybe by another job), else made now by ``make``;
    None where ``make`` wrote none. A cached file that does not read as one (damaged on the disk the jobs share)
    is removed and made again, never handed on: every later job would load it."""
    if out.is_file():
        try:
            return _split_pieces(out.read_bytes(), name)
        except (MeshRejected, ValueError):  # UnicodeDecodeError is a ValueError
            out.unlink(missing_ok=True)
    make()
    return _split_pieces(out.read_bytes(), name) if out.is_file() else None


def _run_vhacd(mesh: TriangleMesh, cache_dir: Path, out: Path, resolution: int) -> None:
    source = cache_dir / f"{mesh.content_id}.{os.getpid()}.src.obj"
    write_obj(mesh.vertices, mesh.faces, source)
    _into_place(source, out, lambda tmp_out: _VHACD.run(source, tmp_out, resolution, timeout=120))


class VhacdChild:
    """One VHACD child process per process (started at the first object, after a fork again), serving objects
    one at a time; it ends when this process does (its stdin closes)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._child: subprocess.Popen | None = None
        self._owner = 0
        atexit.register(self.close)

    def run(self, source: Path, out: Path, resolution: int, timeout: float) -> bool:
        """Decompose ``source`` into ``out``; False when the child crashed on it (twice: a child that died before
        it, killed from outside, is replaced once) or ran past ``timeout`` (ended)."""
        with self._lock:
            for _ in range(2):
                answered = self._ask(source, out, resolution, timeout)
                if answered is not None:
                    return answered
            return False

    def _ask(self, source: Path, out: Path, resolution: int, timeout: float) -> bool | None:
        """True: done; False: past ``timeout``; None: the child died (it is ended either way)."""
        child = self._started()
        try:
            child.stdin.write(json.dumps([str(source), str(out), resolution]) + "\n")
            child.stdin.flush()
            line = child.stdout.readline() if select.select([child.stdout], [], [], timeout)[0] else None
        except OSError:  # BrokenPipeError: it was gone before the request
            line = ""
        if line == "done\n":
            return True
        self._end()
        return None if line is not None else False

    def _started(self) -> subprocess.Popen:
        if self._child is None or self._owner != os.getpid() or self._child.poll() is not None:
            self._child = subprocess.Popen([sys.executable, "-c", _VHACD_SCRIPT], stdin=subprocess.PIPE,
                                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            self._owner = os.getpid()
        return self._child

    def close(self) -> None:
        """End the child: its input closes and it leaves its loop (killed if it does not within seconds)."""
        child = self._child
        if child is not None and self._owner == os.getpid() and child.poll() is None:
            child.stdin.close()
            try:
                child.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._end()

    def _end(self) -> None:
        if self._child is not None and self._owner == os.getpid():
            self._child.kill()
            self._child.wait()
        self._child = None


_VHACD = VhacdChild()


def _run_coacd(mesh: TriangleMesh, cache_dir: Path, out: Path, threshold: float) -> None:
    source = cache_dir / f"{mesh.content_id}.{os.getpid()}.src.npz"
    np.savez(source, vertices=mesh.vertices, faces=mesh.faces)
    _run_child(_COACD_SCRIPT, source, out, (str(threshold),), timeout=600)


def _run_child(script: str, source: Path, out: Path, args: tuple[str, ...], timeout: float) -> None:
    """``script SOURCE TMP ARGS...`` in a child Python of its own (see :func:`_into_place`)."""
    def run(tmp_out: Path) -> bool:
        try:
            subprocess.run([sys.executable, "-c", script, str(source), str(tmp_out), *args], capture_output=True,
                           timeout=timeout, check=False)
        except subprocess.TimeoutExpired:
            return False
        return True

    _into_place(source, out, run)


def _into_place(source: Path, out: Path, decompose: Callable[[Path], bool]) -> None:
    """``decompose(tmp)`` writes a decomposition of ``source`` to a temporary beside ``out`` and says whether it
    finished; moved to ``out`` when it did and wrote one (a crash or a timeout leaves none); the source and any
    partial output removed."""
    tmp_out = out.with_suffix(f".{os.getpid()}.part")
    try:
        if decompose(tmp_out) and tmp_out.is_file() and tmp_out.stat().st_size > 0:
            os.replace(tmp_out, out)
    finally:
        for path in (source, tmp_out):
            path.unlink(missing_ok=True)


def _split_pieces(data: bytes, name: str) -> list[np.ndarray]:
    """VHACD writes one 'o' group per convex piece; vertex indices are global across the file."""
    vertices, _ = parse_obj(data, name)
    pieces, offset = [], 0
    for chunk in data.decode().split("\no "):
        count = sum(1 for line in chunk.splitlines() if line.startswith("v "))
        if count >= 4:
            pieces.append(vertices[offset:offset + count])
        offset += count
    return pieces or [vertices]
