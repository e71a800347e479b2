"""A depth camera's noise taken out of a view before planning (PlanSpec.denoise; docs/planning.md). The networks
learn from exact renders; a real camera moves each point 1-2 mm along its ray. Nothing stands below a table, so
the points just under the support plane are noise alone: their spread measures it (a workspace crop may cut them
short: the deepest of them says where, and a half-normal cut there is fitted to their median). Where it is above
NOISE_FLOOR (a renderer's depth steps are far below), the table takes every point within 3 deviations of it (the
noise no longer leaves table points standing as specks of an object); what lies further below it is noise and is
dropped, and so is the far tail above it, which stands as scattered specks (a point with fewer than
SPECK_NEIGHBOURS others within SPECK_RADIUS); each object point left is moved onto the least-squares plane of its
SMOOTH_NEIGHBOURS nearest (the fuzz off a surface, its shape kept). Pure numpy and scipy's exact k-d tree,
fixed-order products: the same bits on every CPU."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, dot3, neighbour_indices
from onepiece_dist.core.sampling import plane_normals

NOISE_FLOOR = 0.0005  # m: a deviation below this is taken for exact depth and leaves the view as it is
BELOW = 0.02  # m: the points this far under the plane, at most, measure the noise
SMOOTH_NEIGHBOURS = 32  # about 5 mm at a depth camera's 1.7 mm spacing: 2-4 mm of noise chose it (docs/picks.md)
HALF_NORMAL_MAD = 1.4826  # a half-normal's deviation over its median (1 / 0.6745)
SPECK_NEIGHBOURS, SPECK_RADIUS = 4, 0.01  # a point with fewer than 4 others within 1 cm is a speck of noise
# A half-normal of deviation 1 cut at CUT keeps the median CUT_MEDIAN (sqrt(2) erfinv(erf(CUT / sqrt(2)) / 2), tabulated
# so that the same bits come out on every CPU; tests/test_denoise.py computes it again); cut beyond 5 deviations, 1 /
# HALF_NORMAL_MAD within 1e-5.
CUT = np.arange(1.0, 5.01, 0.25)
CUT_MEDIAN = np.array([0.441771, 0.516293, 0.572760, 0.612724, 0.639112, 0.655378, 0.664751, 0.669809, 0.672367,
                       0.673582, 0.674124, 0.674351, 0.674440, 0.674473, 0.674484, 0.674488, 0.674489])
CUT_RATIO = CUT_MEDIAN / CUT  # the median over the cut: falls as the cut lies deeper


def plane_noise(points: np.ndarray, plane: SupportPlane) -> float:
    """The depth noise's deviation (m) as the points up to BELOW under ``plane`` show it: HALF_NORMAL_MAD times
    their median distance under it, or, where the deepest of them lies within 5 deviations (the cloud cut short
    below the table, by a workspace crop or by BELOW), the deviation of a half-normal cut there with their median
    (cut_deviation); 0 where none lies there."""
    distance = plane.distance(points)
    under = -distance[(distance < 0) & (distance > -BELOW)]
    return cut_deviation(float(np.median(under)), float(np.max(under))) if len(under) else 0.0


def cut_deviation(median: float, deepest: float) -> float:
    """The deviation of a half-normal whose draws, cut at ``deepest``, have ``median``: HALF_NORMAL_MAD times the
    median where the cut lies beyond CUT[-1] deviations; at most ``deepest`` (a cut at CUT[0] deviations)."""
    if median <= CUT_RATIO[-1] * deepest:
        return HALF_NORMAL_MAD * median
    return deepest / float(np.interp(median / deepest, CUT_RATIO[::-1], CUT[::-1]))


def widened(points: np.ndarray, plane: SupportPlane, noise: float, tolerance: float) -> SupportPlane:
    """``plane`` with every point within ``tolerance`` or 3 ``noise`` deviations of it its own, and ``noise``."""
    return SupportPlane(plane.normal, plane.offset, np.abs(plane.distance(points)) < max(tolerance, 3 * noise), noise)


def smoothed(points: np.ndarray, neighbours: int = SMOOTH_NEIGHBOURS) -> np.ndarray:
    """(m, 3) each of ``points`` moved onto the least-squares plane of its ``neighbours`` nearest (itself among
    them)."""
    if len(points) < 3:
        return points
    near = points[neighbour_indices(points, points, neighbours)]
    centre = near.mean(axis=1)
    normal = plane_normals(near - centre[:, None, :])
    return points - dot3(points - centre, normal)[:, None] * normal


def denoised(points: np.ndarray, plane: SupportPlane, tolerance: float) -> tuple[SupportPlane, np.ndarray]:
    """``plane`` and the object points off it (the cloud ``points`` less the table's), the camera's noise taken
    out where the points under the plane show one above NOISE_FLOOR (the module's doc); else as they came."""
    noise = plane_noise(points, plane)
    if noise < NOISE_FLOOR:
        return plane, points[~plane.inliers]
    wide = widened(points, plane, noise, tolerance)
    above = points[~wide.inliers & (wide.distance(points) > 0)]  # nothing stands below a table
    return wide, smoothed(without_specks(above))


def without_specks(points: np.ndarray, neighbours: int = SPECK_NEIGHBOURS, radius: float = SPECK_RADIUS) -> np.ndarray:
    """``points`` less those with fewer than ``neighbours`` others within ``radius`` (m): the noise's far tail
    beyond the table's band stands as scattered specks, an object's surface as a dense sheet."""
    if len(points) <= neighbours:
        return points
    nearest = points[neighbour_indices(points, points, neighbours + 1)[:, -1]]
    return points[np.sum((nearest - points) ** 2, axis=1) <= radius * radius]
