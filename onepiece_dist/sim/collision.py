"""Collision geometry for dynamic objects: a convex decomposition, computed once per object content id and
cached as an OBJ of convex pieces; the plain convex hull only when asked (with a warning).

Two decompositions: pybullet's VHACD (the default) and CoACD (collision-aware, Wei et al. 2022; the registry
package ``coacd``, extra ``decompose``), which cuts along concave features instead of voxelizing. Both run in a
child process: they crash on some meshes, and a crash there must not take the worker down.
docs/decomposition.md measures them side by side (benchmarks/experiments/decomposition.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from onepiece_dist.core.mesh import TriangleMesh, enclosed_volume
from onepiece_dist.objects.meshio import parse_obj, write_obj

if TYPE_CHECKING:
    from onepiece_dist.objects import LoadedObject

_VHACD_SCRIPT = """
import sys, pybullet as p
p.connect(p.DIRECT)
p.vhacd(sys.argv[1], sys.argv[2], sys.argv[3], resolution=int(sys.argv[4]), maxNumVerticesPerCH=32)
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
        if not out.is_file():
            _run_coacd(mesh, cache_dir, out, threshold)
        if out.is_file():
            return _split_pieces(out.read_bytes(), mesh.name)
        warnings.warn(f"{mesh.name}: CoACD failed (is the 'coacd' package installed? pip install "
                      "'onepiece-dist[decompose]'); using VHACD", stacklevel=2)
    out = cache_dir / f"{mesh.content_id}-vhacd{resolution}.obj"
    if not out.is_file():
        _run_vhacd(mesh, cache_dir, out, resolution)
    if not out.is_file():
        warnings.warn(f"{mesh.name}: convex decomposition failed; using the convex hull", stacklevel=2)
        return [mesh.vertices]
    return _split_pieces(out.read_bytes(), mesh.name)


def _run_vhacd(mesh: TriangleMesh, cache_dir: Path, out: Path, resolution: int) -> None:
    source = cache_dir / f"{mesh.content_id}.{os.getpid()}.src.obj"
    write_obj(mesh.vertices, mesh.faces, source)
    _run_child(_VHACD_SCRIPT, source, out, (os.devnull, str(resolution)), timeout=120)


def _run_coacd(mesh: TriangleMesh, cache_dir: Path, out: Path, threshold: float) -> None:
    source = cache_dir / f"{mesh.content_id}.{os.getpid()}.src.npz"
    np.savez(source, vertices=mesh.vertices, faces=mesh.faces)
    _run_child(_COACD_SCRIPT, source, out, (str(threshold),), timeout=600)


def _run_child(script: str, source: Path, out: Path, args: tuple[str, ...], timeout: float) -> None:
    """``script SOURCE TMP ARGS...`` in a child Python; its output moved to ``out`` when it wrote one (a crash or
    a timeout leaves none); the source and any partial output removed."""
    tmp_out = out.with_suffix(f".{os.getpid()}.part")
    try:
        subprocess.run([sys.executable, "-c", script, str(source), str(tmp_out), *args], capture_output=True,
                       timeout=timeout, check=False)
        if tmp_out.is_file() and tmp_out.stat().st_size > 0:
            os.replace(tmp_out, out)
    except subprocess.TimeoutExpired:
        pass
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
