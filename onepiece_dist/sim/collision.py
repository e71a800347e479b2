"""Collision geometry for dynamic objects: a convex decomposition (pybullet's VHACD), computed once per object
content id and cached as an OBJ of convex pieces; the plain convex hull only when asked (with a warning).

VHACD runs in a child process: it segfaults on some meshes, and a crash there must not take the worker down.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

from onepiece_dist.core.mesh import TriangleMesh
from onepiece_dist.objects.meshio import parse_obj, write_obj

_VHACD_SCRIPT = """
import sys, pybullet as p
p.connect(p.DIRECT)
p.vhacd(sys.argv[1], sys.argv[2], sys.argv[3], resolution=int(sys.argv[4]), maxNumVerticesPerCH=32)
"""


def convex_pieces(mesh: TriangleMesh, cache_dir: Path, method: str = "vhacd",
                  resolution: int = 50_000) -> list[np.ndarray]:
    """Convex pieces of ``mesh`` as a list of (k, 3) float64 vertex arrays (each the hull of its points)."""
    if method == "hull":
        warnings.warn(f"{mesh.name}: collision geometry is the convex hull; grasps on concave parts are distorted",
                      stacklevel=2)
        return [mesh.vertices]
    cache_dir.mkdir(parents=True, exist_ok=True)
    out = cache_dir / f"{mesh.content_id}-vhacd{resolution}.obj"
    if not out.is_file():
        _run_vhacd(mesh, cache_dir, out, resolution)
    if not out.is_file():
        warnings.warn(f"{mesh.name}: convex decomposition failed; using the convex hull", stacklevel=2)
        return [mesh.vertices]
    return _split_pieces(out.read_bytes(), mesh.name)


def _run_vhacd(mesh: TriangleMesh, cache_dir: Path, out: Path, resolution: int) -> None:
    source = cache_dir / f"{mesh.content_id}.src.obj"
    write_obj(mesh.vertices, mesh.faces, source)
    tmp_out = out.with_suffix(f".{os.getpid()}.part")
    try:
        subprocess.run([sys.executable, "-c", _VHACD_SCRIPT, str(source), str(tmp_out), os.devnull,
                        str(resolution)], capture_output=True, timeout=120, check=False)
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
