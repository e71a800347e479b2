"""Convex pieces clipped to an axis-aligned box, exactly (pure numpy).

A convex piece is given by points whose convex hull it is (how pybullet and VHACD give them). Clipping the hull
by one plane keeps the points on the inner side and adds the points where the plane cuts the hull's edges. Every
edge of the hull joins two of its points, so cutting every segment between an inner and an outer point finds
all of them (and only points of the hull); their 2D hull in the plane is the cap. The result of each cut is again
a set of points whose hull is the clipped piece, so six cuts clip to a box, and a clipped piece stays convex.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.mesh import merge_meshes
from onepiece_dist.core.raycast import import_open3d

EPS = 1e-12
MISS = 1e-9  # a piece whose bounds lie further than this outside the box is cut away whole, without cutting


def clip_to_box(points: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The hull of ``points`` (k, 3) intersected with the box [lower, upper] (3,), as (m, 3) float64 points whose
    hull it is: the piece's points inside the box and the vertices of each cut face, without duplicates; (0, 3)
    when the piece misses the box or only touches it (no volume)."""
    out = np.asarray(points, dtype=np.float64)
    if len(out) == 0 or np.any(out.min(axis=0) > upper + MISS) or np.any(out.max(axis=0) < lower - MISS):
        return np.zeros((0, 3))  # the piece's bounds miss the box: the cuts below would leave nothing either
    for axis in range(3):
        out = _cut(out, axis, float(lower[axis]), keep_above=True)
        out = _cut(out, axis, float(upper[axis]), keep_above=False)
        if len(out) < 4:
            return np.zeros((0, 3))
    out = out[first_of_equal_rows(np.round(out, 12))]
    return out if len(out) >= 4 and np.ptp(out, axis=0).min() > 1e-9 else np.zeros((0, 3))


def _cut(points: np.ndarray, axis: int, level: float, keep_above: bool) -> np.ndarray:
    """Points of the hull of ``points`` on one side of the plane x[axis] = level."""
    side = points[:, axis] - level if keep_above else level - points[:, axis]
    keep = side >= -EPS
    if keep.all() or not keep.any():  # most cuts miss the piece or take all of it
        return points if keep.all() else np.zeros((0, 3))
    inner, outer, d_in, d_out = points[keep], points[~keep], side[keep], side[~keep]
    t = d_in[:, None] / (d_in[:, None] - d_out[None, :])  # (i, o) where the segment meets the plane
    cuts = inner[:, None, :] + t[..., None] * (outer[None, :, :] - inner[:, None, :])
    on_plane = d_in <= EPS
    cap = np.vstack([cuts.reshape(-1, 3), inner[on_plane]])
    cap[:, axis] = level
    others = [a for a in range(3) if a != axis]
    return np.vstack([inner[~on_plane], cap[_hull_2d(cap[:, others])]])


def _hull_2d(points: np.ndarray) -> np.ndarray:
    """Indices of the vertices of the 2D convex hull of (n, 2) points (Andrew's monotone chain)."""
    if len(points) < 3:
        return np.arange(len(points))
    unique = first_of_equal_rows(np.round(points, 12))
    order = unique[np.lexsort((points[unique, 1], points[unique, 0]))]
    if len(order) < 3:
        return order
    order = order[~_inside_extremes(points[order])]  # Akl-Toussaint: most cut points are inside the cap

    xy = points.tolist()  # plain floats: the same IEEE arithmetic as numpy's, without a scalar per access

    def chain(indices: list[int]) -> list[int]:
        hull: list[int] = []
        for i in indices:
            px, py = xy[i]
            while len(hull) >= 2:
                (ox, oy), (ax, ay) = xy[hull[-2]], xy[hull[-1]]
                if (ax - ox) * (py - oy) - (ay - oy) * (px - ox) > 0:  # a left turn: keep
                    break
                hull.pop()
            hull.append(i)
        return hull

    ordered = order.tolist()
    lower, upper = chain(ordered), chain(ordered[::-1])
    return np.array(lower[:-1] + upper[:-1], dtype=np.int64)


def first_of_equal_rows(rows: np.ndarray) -> np.ndarray:
    """(k,) int64 ascending indices of the first of each group of equal rows of (n, d) ``rows``: the indices
    ``np.unique(rows, axis=0, return_index=True)`` gives, sorted, at a quarter of its cost on small arrays (a
    stable lexsort of the columns instead of a sort of the rows as structured items)."""
    if len(rows) == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort(rows.T[::-1])  # stable: each group of equal rows keeps its first row first
    ordered = rows[order]
    starts = np.ones(len(rows), dtype=bool)
    starts[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    return np.sort(order[starts]).astype(np.int64)


def _inside_extremes(points: np.ndarray, margin: float = 1e-12) -> np.ndarray:
    """(n,) bool: points strictly inside (by ``margin``) the polygon of the extreme points in eight directions
    (Akl-Toussaint). That polygon lies in the hull, so its interior lies in the hull's interior: none of these
    points is a hull vertex, and the monotone chain gives the same hull without them."""
    x, y = points[:, 0], points[:, 1]
    extremes = [np.argmin(x), np.argmin(x + y), np.argmin(y), np.argmax(x - y), np.argmax(x), np.argmax(x + y),
                np.argmax(y), np.argmin(x - y)]  # counter-clockwise around the hull
    corners = [int(i) for k, i in enumerate(extremes) if i != extremes[k - 1]]
    if len(set(corners)) < 3:
        return np.zeros(len(points), dtype=bool)
    a = points[corners]
    b = np.roll(a, -1, axis=0)  # (e, 2) each edge's start and end; every edge's test at once, the same arithmetic
    left = (b[:, :1] - a[:, :1]) * (y - a[:, 1:]) - (b[:, 1:] - a[:, 1:]) * (x - a[:, :1])  # (e, n)
    return np.all(left > margin, axis=0)


def hull_mesh(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh of the convex hull of (k, 3) points: vertices (n, 3) float64, faces (f, 3) int64 wound
    outward (open3d's qhull, imported where used)."""
    o3d = import_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(points, dtype=np.float64)))
    hull, _ = cloud.compute_convex_hull(joggle_inputs=False)
    vertices, faces = np.asarray(hull.vertices, dtype=np.float64), np.asarray(hull.triangles, dtype=np.int64)
    tri = vertices[faces] - vertices.mean(axis=0)
    if np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() < 0:
        faces = faces[:, ::-1]
    return vertices, faces


def pieces_mesh(pieces: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One triangle mesh (vertices, faces) of convex pieces, each the hull of its (k, 3) points: what a patch
    or a source object is as the simulation sees it (views are rendered and contacts found on it)."""
    return merge_meshes([hull_mesh(piece) for piece in pieces])
