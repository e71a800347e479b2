"""Is a fitted plane the table the objects stand on (issue 56)? A box's side seen head-on can hold more points than
the table. A support plane holds the objects: most points well off it (further than FAR: a noisy table's own
points stand nearer) lie above it (on the side its normal points to, the camera's); and where the frame's up is
known (a camera pose puts the cloud in the robot's base frame) it faces up, within MAX_TILT_DEG. Otherwise the
planner looks again among the points off that plane, once. Without a known up, a box's side facing the camera with
the table seen in front of it cannot be told from the table."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, dot3, fit_support_plane

FAR = 0.01  # m: off the plane further than a depth camera's noise (3 deviations of 3 mm) leaves the table's points
MIN_SHARE = 0.5  # of the points off the plane that must stand above it
MAX_TILT_DEG = 45.0  # between a table's normal and the frame's up

PLANE_TOLERANCE = 0.004  # m: a point this near the support plane is the table's


def holds_objects(points: np.ndarray, plane: SupportPlane, up: np.ndarray | None = None) -> bool:
    """Whether most of ``points`` (m, 3) further than FAR off ``plane`` lie above it (True where none is) and, with
    ``up`` (3,) the frame's known up, whether the plane faces up."""
    if up is not None:
        up = np.asarray(up, dtype=np.float64)
        if dot3(plane.normal, up) < np.cos(np.radians(MAX_TILT_DEG)) * np.sqrt(dot3(up, up)):
            return False
    distance = plane.distance(points[~plane.inliers])
    far = distance[np.abs(distance) > FAR]  # a noisy table's tails stand nearer it, as many under it as over it
    return len(far) == 0 or float(np.mean(far > 0)) >= MIN_SHARE


def support_plane(points: np.ndarray, rng: np.random.Generator, towards: np.ndarray | None = None,
                  up: np.ndarray | None = None, tolerance: float = PLANE_TOLERANCE) -> SupportPlane | None:
    """The plane the objects stand on: the dominant plane (core.cloud.grasps.fit_support_plane, its normal along
    ``towards``, the camera's side) checked by :func:`holds_objects`; when it holds nothing, the dominant plane of
    the points off it, once; None when neither does."""
    plane = fit_support_plane(points, rng, up=towards if up is None else up, tolerance=tolerance)
    if plane is None or holds_objects(points, plane, up):
        return plane
    rest = ~plane.inliers
    second = fit_support_plane(points[rest], rng, up=towards if up is None else up, tolerance=tolerance)
    if second is None:
        return None
    again = SupportPlane(second.normal, second.offset, np.abs(second.distance(points)) < tolerance)
    return again if holds_objects(points, again, up) else None
