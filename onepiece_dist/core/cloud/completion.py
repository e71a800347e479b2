"""The shape one depth view implies of an object standing on a support plane: every observed point and its shadow
on the plane, and the convex hull of them all (what lies under what the camera saw, down to the table, taken as
solid). Given in the plane's frame, moved along it to stand over the origin: the plane is z = 0 and its normal
+z, so a pick world's table stands in for it wherever the camera's or the robot's frame put the object. A convex
hull fills a mug's or a bowl's opening; carved (where the camera's position is known), the hull loses every voxel
the camera saw through, so an opening it looked into stays open and what it could not see stays solid; mirrored,
it also holds the points' half turn about their vertical axis (a symmetric object's far side). Each is what a
planner can check a grasp against in simulation before it moves (picks.shape_check), not the object."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, dot3
from onepiece_dist.core.cloud.swept_space import TRUNCATION, DepthRays
from onepiece_dist.core.frames import perpendicular

VOLUME_DECIMALS = 9  # m^3: a mass from the hull's volume the same on every CPU
CARVE_VOXEL = 0.004  # m: the carved shape's voxels, about a ray's width at the benchmark's camera distance
CARVE_FILL = 0.1  # a convex piece may fill this share of its voxels' volume more (fewer pieces: faster)
STAIRS = 1.0  # and this many voxels per four of its corners more
SEEN_THROUGH = 0.005  # m: a voxel's centre this far in front of the observed surface along its ray is free


@dataclass(frozen=True)
class CompletedShape:
    """``pieces``: (k, 3) vertex arrays of its convex pieces (the plane's frame, its footprint's middle at the
    origin; m): the hull alone, or the carved hull's pieces; its ``volume`` (m^3), and ``to_plane`` (4, 4): the
    cloud's frame to that frame."""

    pieces: tuple[np.ndarray, ...]
    volume: float
    to_plane: np.ndarray


def plane_frame(plane: SupportPlane) -> np.ndarray:
    """(4, 4) the cloud's frame to the plane's: its normal turned to +z, the plane at z = 0."""
    z = plane.normal / np.sqrt(dot3(plane.normal, plane.normal))
    x = perpendicular(z[None])[0]
    y = np.cross(z, x)
    out = np.eye(4)
    out[:3, :3] = np.stack([x, y, z])
    out[:3, 3] = out[:3, :3] @ (plane.offset * z)  # a point on the plane, -offset * normal, goes to the origin
    return out


def completed_shape(points: np.ndarray, plane: SupportPlane, rays: DepthRays | None = None,
                    voxel: float = CARVE_VOXEL, fill: float = CARVE_FILL, mirror: bool = False
                    ) -> CompletedShape | None:
    """The hull of the object's observed ``points`` (m, 3; the cloud less the plane) and their shadows on
    ``plane``, with ``mirror`` their half turn about the vertical axis too (mirrored), carved by ``rays`` (the
    whole cloud's depth from the camera, core.cloud.swept_space) into pieces of ``voxel`` where given; None when
    they span no volume (fewer than 4 points, or all on one plane)."""
    from scipy.spatial import ConvexHull, QhullError

    to_plane = plane_frame(plane)
    local = np.asarray(points, dtype=np.float64) @ to_plane[:3, :3].T + to_plane[:3, 3]
    local = local[local[:, 2] > 0]
    if len(local) < 4:
        return None
    if mirror:
        local = np.vstack([local, mirrored(local)])
    middle = (local[:, :2].min(axis=0) + local[:, :2].max(axis=0)) / 2  # over the middle of a world's table
    local[:, :2] -= middle
    to_plane[:2, 3] -= middle
    shadows = local.copy()
    shadows[:, 2] = 0.0
    both = np.vstack([local, shadows])
    try:
        hull = ConvexHull(both)
    except QhullError:
        return None
    if rays is None:
        return CompletedShape((both[hull.vertices],), round(float(hull.volume), VOLUME_DECIMALS), to_plane)
    return carved(both[hull.vertices], hull.equations, to_plane, rays, voxel, fill)


def mirrored(local: np.ndarray) -> np.ndarray:
    """``local`` (m, 3; the plane's frame) turned half a turn about the vertical axis through the centre of the
    circle that best fits their footprint (a can's axis, about a box's middle: what a symmetric object shows of its
    far side), or through their mean where that circle's centre lies further from it than their footprint's span."""
    xy = local[:, :2]
    design = np.column_stack([2 * xy, np.ones(len(xy))])
    centre = np.linalg.lstsq(design, xy[:, 0] ** 2 + xy[:, 1] ** 2, rcond=None)[0][:2]
    mean = xy.mean(axis=0)
    if not np.all(np.isfinite(centre)) or np.hypot(*(centre - mean)) > np.ptp(xy, axis=0).max():
        centre = mean
    out = local.copy()
    out[:, :2] = 2 * centre - xy
    return out


def carved(vertices: np.ndarray, facets: np.ndarray, to_plane: np.ndarray, rays: DepthRays,
           voxel: float, fill: float = CARVE_FILL) -> CompletedShape | None:
    """The voxels of ``voxel`` whose centres lie inside the hull (``vertices``; ``facets`` (f, 4) its outward
    planes, plane frame) and not SEEN_THROUGH in front of the observed surface along their ray, as convex pieces
    (_pieces, at most ``fill`` fuller than their voxels); None when no voxel is left."""
    low = vertices.min(axis=0)
    counts = np.maximum(np.ceil((vertices.max(axis=0) - low) / voxel).astype(np.int64), 1)
    axes = [low[a] + (np.arange(counts[a]) + 0.5) * voxel for a in range(3)]
    grid = np.stack([c.ravel() for c in np.meshgrid(*axes, indexing="ij")], axis=1)
    inside = np.ones(len(grid), bool)
    for a, b, c, d in facets:  # fixed-order products: the same voxels on every CPU
        inside &= ((grid[:, 0] * a + grid[:, 1] * b) + grid[:, 2] * c) + d <= 1e-9
    shifted, rot = grid[inside] - to_plane[:3, 3], to_plane[:3, :3]  # the plane's frame back to the cloud's
    in_cloud = np.stack([(shifted[:, 0] * rot[0, k] + shifted[:, 1] * rot[1, k]) + shifted[:, 2] * rot[2, k]
                         for k in range(3)], axis=1)
    solid = np.zeros(len(grid), bool)
    solid[np.flatnonzero(inside)] = rays.read(in_cloud) <= SEEN_THROUGH / TRUNCATION
    solid = solid.reshape(tuple(counts))
    if not solid.any():
        return None
    pieces = [low + corners * voxel for corners in _pieces(solid, fill)]
    return CompletedShape(tuple(pieces), round(float(solid.sum()) * voxel**3, VOLUME_DECIMALS), to_plane)


def _pieces(solid: np.ndarray, fill: float) -> list[np.ndarray]:
    """Convex pieces (vertices, voxel units) covering ``solid`` (nx, ny, nz): the footprint halved as a quadtree
    until the hull of a square's voxels (each column's runs along z) adds at most ``fill`` of their own volume
    and STAIRS voxels per four of its distinct corners (a sloped top's steps), or the square is one column."""
    size = 1 << int(np.ceil(np.log2(max(solid.shape[0], solid.shape[1], 1))))
    out: list[np.ndarray] = []
    _split(solid, 0, 0, size, fill, out)
    return out


def _split(solid: np.ndarray, x0: int, y0: int, size: int, fill: float, out: list[np.ndarray]) -> None:
    from scipy.spatial import ConvexHull

    block = solid[x0:x0 + size, y0:y0 + size]
    if not block.any():
        return
    corners = []
    for ix, iy in zip(*np.nonzero(block.any(axis=2)), strict=True):
        edges = np.flatnonzero(np.diff(np.r_[0, block[ix, iy].astype(np.int8), 0]))
        corners += [(x0 + x, y0 + y, z) for x in (ix, ix + 1) for y in (iy, iy + 1) for z in edges]
    corners = np.unique(np.array(corners, dtype=np.float64), axis=0)
    hull = ConvexHull(corners)
    if size == 1 or hull.volume - block.sum() <= fill * block.sum() + STAIRS * len(corners) / 4:
        out.append(corners[hull.vertices])
        return
    half = size // 2
    for dx, dy in ((0, 0), (half, 0), (0, half), (half, half)):
        _split(solid, x0 + dx, y0 + dy, half, fill, out)
