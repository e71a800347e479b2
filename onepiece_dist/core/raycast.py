"""First hits of rays on a triangle mesh, the same bits on every CPU.

open3d's ray casting is Embree's, in float32, on a SIMD kernel and a BVH that Embree picks for the CPU it runs on
(from the CPU's features and, on Intel, its model; no environment variable reaches that choice): the distance it
reports for one ray moves by a float32 ULP or more from one machine to another, and so may which of two triangles
meeting at an edge it names. The antipodal sampler builds each candidate's centre and width from these hits, and
pybullet turns a last-bit change of a candidate into another settled pose now and then, so Embree's kernel would
decide which patches the one object gets and the codes of the grasps labelled on them (an AVX-512 Sapphire Rapids
machine and an AMD EPYC gave the same extraction codes and other label-stage codes).

Here Embree only says which triangle each ray met. The hit is computed again in float64 with products and sums of
one fixed order (Moller-Trumbore) against that triangle and every triangle sharing a vertex position with it; the
nearest hit wins, ties to the lowest face index. Embree's distance and normal never leave this module. Left to
Embree: whether a ray hits at all (a ray that grazes a silhouette) and surfaces that touch without sharing a
vertex, where another kernel may name a triangle outside the ring.

Every module of the package imports open3d through :func:`import_open3d`, without its plotly front end.
"""

from __future__ import annotations

import sys
import types
from dataclasses import dataclass

import numpy as np

EDGE_TOLERANCE = 1e-9  # barycentric slack: a ray through an edge hits both triangles, never neither


@dataclass(frozen=True)
class RayHits:
    """t (k,) float64 distance along each unit direction (inf: no hit); face (k,) int64 triangle hit (-1: none);
    normal (k, 3) float64 unit normal of that triangle by its winding (0 where none)."""

    t: np.ndarray
    face: np.ndarray
    normal: np.ndarray


def cast_rays(vertices: np.ndarray, faces: np.ndarray, origins: np.ndarray, directions: np.ndarray) -> RayHits:
    """First hit of each ray (origins, directions (k, 3) float64, directions unit) on the mesh, the same bits on
    every CPU: Embree names a triangle, :func:`exact_hits` decides."""
    return exact_hits(vertices, faces, origins, directions, embree_faces(vertices, faces, origins, directions))


def embree_faces(vertices: np.ndarray, faces: np.ndarray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(k,) int64 the triangle open3d's ray casting (Embree, float32) reports for each ray, -1 for a miss."""
    o3d = import_open3d()

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.ascontiguousarray(faces, dtype=np.uint32)))
    rays = np.hstack([origins, directions]).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))
    found = hit["primitive_ids"].numpy().astype(np.int64)
    return np.where(np.isfinite(hit["t_hit"].numpy()), found, -1)


PLOTLY_FRONT_END = "open3d.visualization.draw_plotly"


def import_open3d() -> types.ModuleType:
    """open3d, imported without its plotly front end where this process has not imported open3d yet. open3d's
    ``__init__`` imports ``open3d.visualization.draw_plotly``, which imports plotly and dash: half of open3d's
    import (about 0.45 of 1 CPU-second), paid by every worker process that samples grasps, for drawing nothing
    here uses. Its functions, in such a process, raise and say how to have them."""
    if "open3d" not in sys.modules and PLOTLY_FRONT_END not in sys.modules:
        sys.modules[PLOTLY_FRONT_END] = _without_plotly()
    import open3d

    return open3d


def _without_plotly() -> types.ModuleType:
    front_end = types.ModuleType(PLOTLY_FRONT_END)

    def missing(name: str):
        if name.startswith("_"):  # __file__, __path__ and the like: a module without them, as Python expects
            raise AttributeError(name)

        def unavailable(*args, **kwargs):
            raise RuntimeError(f"open3d.visualization.{name} is not loaded in this process: onepiece_dist imports "
                               "open3d without its plotly front end; import open3d before onepiece_dist to use it")

        return unavailable

    front_end.__getattr__ = missing
    return front_end


def exact_hits(vertices: np.ndarray, faces: np.ndarray, origins: np.ndarray, directions: np.ndarray,
               named: np.ndarray) -> RayHits:
    """The nearest float64 hit of each ray among the triangles that share a vertex position with its ``named``
    triangle (k,) int64 (-1: the ray missed, and stays a miss)."""
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    origins, directions = np.asarray(origins, dtype=np.float64), np.asarray(directions, dtype=np.float64)
    k = len(origins)
    t, face = np.full(k, np.inf), np.full(k, -1, dtype=np.int64)
    rays = np.flatnonzero(named >= 0)
    if len(rays):
        ray, member = ring_pairs(vertices, faces, named[rays])
        ray = rays[ray]
        tri = vertices[faces[member]]
        t_pair = triangle_distances(tri, origins[ray], directions[ray])
        hit = np.isfinite(t_pair)
        ray, member, t_pair = ray[hit], member[hit], t_pair[hit]
        order = np.lexsort((member, t_pair, ray))  # per ray, nearest first, then the lowest face
        first = order[np.r_[True, ray[order][1:] != ray[order][:-1]]] if len(order) else order
        t[ray[first]], face[ray[first]] = t_pair[first], member[first]
        lost = rays[face[rays] < 0]  # named by Embree, missed by every exact test: its named triangle's plane
        t[lost], face[lost] = plane_distances(vertices[faces[named[lost]]], origins[lost], directions[lost]), \
            named[lost]
        face[~np.isfinite(t)] = -1
    normal = np.zeros((k, 3))
    got = face >= 0
    normal[got] = unit_normals(vertices[faces[face[got]]])
    return RayHits(t, face, normal)


def ring_pairs(vertices: np.ndarray, faces: np.ndarray, named: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ray, face) int64 pairs: for each ray i, every triangle with a vertex at a position of triangle
    ``named[i]`` (its own included; vertices at one position count as one, so an unwelded mesh has rings too)."""
    _, welded = np.unique(vertices, axis=0, return_inverse=True)
    corner = welded.reshape(-1)[faces]  # (F, 3) position ids
    by_position = np.argsort(corner.reshape(-1), kind="stable")
    faces_at = by_position // 3  # faces in position order
    start = np.searchsorted(corner.reshape(-1)[by_position], np.arange(int(welded.max()) + 2))
    positions = corner[named].reshape(-1)  # (3k,) the named triangles' corners
    counts = start[positions + 1] - start[positions]
    segment = np.repeat(np.arange(len(positions)), counts)
    within = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    return segment // 3, faces_at[start[positions][segment] + within]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row dot products of (..., 3) arrays, summed in one fixed order."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row cross products of (..., 3) arrays, each component one product minus another."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def triangle_distances(tri: np.ndarray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(n,) float64 distance at which ray i meets triangle ``tri[i]`` (n, 3, 3) ahead of its origin, inf where it
    passes by (Moller-Trumbore in float64, barycentric slack EDGE_TOLERANCE)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = cross(directions, e2)
    det = dot(e1, p)
    ok = np.abs(det) > 1e-300
    inv = 1.0 / np.where(ok, det, 1.0)
    s = origins - tri[:, 0]
    u = dot(s, p) * inv
    q = cross(s, e1)
    v = dot(directions, q) * inv
    t = dot(e2, q) * inv
    ok &= (u >= -EDGE_TOLERANCE) & (v >= -EDGE_TOLERANCE) & (u + v <= 1 + EDGE_TOLERANCE) & (t > 0)
    return np.where(ok, t, np.inf)


def plane_distances(tri: np.ndarray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(n,) float64 distance at which ray i meets the plane of ``tri[i]``, inf when parallel or behind it."""
    n = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    along = dot(directions, n)
    ok = np.abs(along) > 1e-300
    t = dot(tri[:, 0] - origins, n) / np.where(ok, along, 1.0)
    return np.where(ok & (t > 0), t, np.inf)


def unit_normals(tri: np.ndarray) -> np.ndarray:
    """(n, 3) float64 unit normals of (n, 3, 3) triangles by their winding."""
    n = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.maximum(np.sqrt(dot(n, n)), 1e-300)[:, None]
