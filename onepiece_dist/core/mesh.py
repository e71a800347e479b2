"""Triangle meshes as plain arrays: validation, content id, surface sampling.

A mesh is ``vertices (n, 3) float64`` in metres and ``faces (m, 3) int64`` indexing them.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from onepiece_dist.core.portable import sin_cos
from onepiece_dist.core.repair import closed_volume
from onepiece_dist.errors import MeshRejected

MIN_FACE_AREA = 1e-14


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A validated mesh. Build it with :func:`make_mesh`; the arrays are read-only."""

    vertices: np.ndarray
    faces: np.ndarray
    name: str = ""
    content_id: str = field(default="")

    @property
    def extents(self) -> np.ndarray:
        """(3,) float64 axis-aligned bounding-box size."""
        return np.ptp(self.vertices, axis=0)


def make_mesh(vertices: np.ndarray, faces: np.ndarray, source: str, scale: float = 1.0) -> TriangleMesh:
    """Validate, scale, drop degenerate faces and hash. Raises :class:`MeshRejected` naming ``source``."""
    vertices = np.asarray(vertices, dtype=np.float64) * float(scale)
    faces = np.asarray(faces)
    validate_arrays(vertices, faces, source)
    faces = faces.astype(np.int64)
    keep = face_areas(vertices, faces) > MIN_FACE_AREA
    if not keep.any():
        raise MeshRejected(source, "every face is degenerate (zero area)")
    faces = faces[keep]
    for arr in (vertices, faces):
        arr.flags.writeable = False
    return TriangleMesh(vertices, faces, name=source, content_id=content_id(vertices, faces))


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The volume the faces enclose, negative when they are wound inwards (clockwise seen from outside)."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    return float(np.sum(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))) / 6.0)


def wound_outwards(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, bool]:
    """``faces`` (F, 3) wound outwards: reversed (``faces[:, ::-1]``) when their signed volume is negative; and
    whether they were. The antipodal sampler casts rays along the inward normal, so an inward-wound mesh would
    yield no grasp at all. An open surface's holes are capped first (core.repair.closed_volume): its plain
    signed volume depends on where the origin lies."""
    if closed_volume(vertices, faces)[0] < 0:
        return np.ascontiguousarray(np.asarray(faces)[:, ::-1]), True
    return faces, False


def validate_arrays(vertices: np.ndarray, faces: np.ndarray, source: str) -> None:
    """Reject what would crash or silently poison a simulator."""
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) < 3:
        raise MeshRejected(source, f"vertices must be (n>=3, 3), got shape {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise MeshRejected(source, f"faces must be (m>=1, 3) triangles, got shape {faces.shape}")
    if not np.issubdtype(faces.dtype, np.integer):
        raise MeshRejected(source, f"face indices must be integers, got {faces.dtype}")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise MeshRejected(source, f"{int(bad.sum())} vertices are not finite (NaN or Inf), "
                                   f"first at index {int(np.argmax(bad))}")
    lo, hi = int(faces.min()), int(faces.max())
    if lo < 0 or hi >= len(vertices):
        raise MeshRejected(source, f"face index out of range: [{lo}, {hi}] with {len(vertices)} vertices")


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) float64 triangle areas."""
    tri = vertices[faces]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 3) float64 unit normals by the right-hand rule on each face's winding."""
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def content_id(vertices: np.ndarray, faces: np.ndarray) -> str:
    """32-hex-digit id of the geometry (vertices already scaled, rounded to 0.1 micrometre)."""
    h = hashlib.blake2b(digest_size=16)
    h.update(np.round(vertices * 1e7).astype("<i8").tobytes())
    h.update(faces.astype("<i8").tobytes())
    return h.hexdigest()


def sample_surface(mesh: TriangleMesh, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted uniform surface samples.

    returns : points (count, 3) float64, normals (count, 3) float64 (face normals, by winding)
    """
    areas = face_areas(mesh.vertices, mesh.faces)
    face = rng.choice(len(areas), size=count, p=areas / areas.sum())
    r1, r2 = rng.random(count), rng.random(count)
    flip = r1 + r2 > 1
    r1, r2 = np.where(flip, 1 - r1, r1), np.where(flip, 1 - r2, r2)
    tri = mesh.vertices[mesh.faces[face]]
    points = tri[:, 0] + r1[:, None] * (tri[:, 1] - tri[:, 0]) + r2[:, None] * (tri[:, 2] - tri[:, 0])
    return points, face_normals(mesh.vertices, mesh.faces)[face]


def min_width(points: np.ndarray) -> float:
    """Smallest extent of the principal-axes bounding box of (n, 3) points: a bound on the narrowest grasp."""
    centred = points - points.mean(axis=0)
    _, _, axes = np.linalg.svd(centred[:: max(1, len(points) // 5000)], full_matrices=False)
    return float(np.ptp(centred @ axes.T, axis=0).min())


def box_mesh(extents: tuple[float, float, float], name: str = "box") -> TriangleMesh:
    """Axis-aligned box centred at the origin, outward winding."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return make_mesh(corners * np.asarray(extents) / 2, faces, name)


def cylinder_mesh(radius: float, height: float, sections: int = 32, name: str = "cylinder") -> TriangleMesh:
    """Closed cylinder along z centred at the origin, outward winding."""
    ang = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    sin, cos = sin_cos(ang)
    ring = np.stack([radius * cos, radius * sin], axis=1)
    verts = np.vstack([np.c_[ring, np.full(sections, -height / 2)], np.c_[ring, np.full(sections, height / 2)],
                       [[0, 0, -height / 2], [0, 0, height / 2]]])
    i = np.arange(sections)
    j = (i + 1) % sections
    bottom, top = 2 * sections, 2 * sections + 1
    faces = np.vstack([np.c_[i, j, j + sections], np.c_[i, j + sections, i + sections],
                       np.c_[np.full(sections, bottom), j, i], np.c_[np.full(sections, top), i + sections,
                                                                      j + sections]])
    return make_mesh(verts, faces, name)


def sphere_mesh(radius: float, rings: int = 12, sectors: int = 24, name: str = "sphere") -> TriangleMesh:
    """UV sphere centred at the origin, outward winding."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, sectors, endpoint=False)
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    (sin_th, cos_th), (sin_ph, cos_ph) = sin_cos(th), sin_cos(ph)
    body = np.stack([sin_th * cos_ph, sin_th * sin_ph, cos_th], axis=-1).reshape(-1, 3)
    verts = np.vstack([[[0, 0, 1]], body, [[0, 0, -1]]]) * radius
    ring = lambda r: 1 + r * sectors + np.arange(sectors)  # noqa: E731
    nxt = lambda r: 1 + r * sectors + (np.arange(sectors) + 1) % sectors  # noqa: E731
    faces = [np.c_[np.zeros(sectors, int), ring(0), nxt(0)]]
    for r in range(rings - 2):
        faces += [np.c_[ring(r), ring(r + 1), nxt(r + 1)], np.c_[ring(r), nxt(r + 1), nxt(r)]]
    south = len(verts) - 1
    faces.append(np.c_[np.full(sectors, south), nxt(rings - 2), ring(rings - 2)])
    return make_mesh(verts, np.vstack(faces), name)


def merge_meshes(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate (vertices (n_i, 3), faces (m_i, 3)) pairs into one pair."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts])[:-1]
    return (np.vstack([v for v, _ in parts]),
            np.vstack([np.asarray(f, dtype=np.int64) + o for (_, f), o in zip(parts, offsets, strict=True)]))


def enclosed_volume(mesh: TriangleMesh) -> float:
    """Volume by the divergence theorem (exact for closed meshes), an open surface's holes capped first
    (core.repair.closed_volume); half the bounding box when that gives ~0."""
    volume = abs(closed_volume(mesh.vertices, mesh.faces)[0])
    return volume if volume > 1e-9 else 0.5 * float(np.prod(np.maximum(mesh.extents, 1e-3)))


def resample_points(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """(k, 3) -> (count, 3) drawn with replacement (zeros when k == 0)."""
    if len(points) == 0:
        return np.zeros((count, 3))
    return points[rng.integers(0, len(points), count)]


def resample_crops(inside: list[np.ndarray], count: int, rng: np.random.Generator) -> np.ndarray:
    """(n, P, 3) float16: each grasp's gripper-frame points inside its closing region ((k_i, 3) each), resampled
    to P = ``count`` in grasp order: the network's point input, the same for the training crops of a job and
    for a planner's crops of a camera's cloud."""
    out = np.zeros((len(inside), count, 3), dtype=np.float16)
    for i, points in enumerate(inside):
        out[i] = resample_points(points, count, rng)
    return out


def solid_properties(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume (m^3), centre of mass (3,) and inertia tensor (3, 3) about it per unit density of the solid a
    closed, outward-wound triangle mesh bounds (signed tetrahedra from the origin; exact for polyhedra)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    signed = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    volume = float(signed.sum())
    if abs(volume) < 1e-15:
        return 0.0, vertices.mean(axis=0), np.zeros((3, 3))
    com = (signed[:, None] * (a + b + c)).sum(axis=0) / (4.0 * volume)
    # second moments of each tetrahedron (0, a, b, c): integral of x_i x_j = V/20 (sum_k p_i p_j + (sum p)_i (sum p)_j)
    s = a + b + c
    second = (np.einsum("n,ni,nj->ij", signed, s, s) + sum(np.einsum("n,ni,nj->ij", signed, p, p) for p in (a, b, c)))
    second /= 20.0
    second -= volume * np.outer(com, com)  # about the centre of mass
    inertia = np.trace(second) * np.eye(3) - second
    return volume, com, inertia
