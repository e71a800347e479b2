"""The shape one depth view implies of an object standing on a support plane: every observed point and its shadow
on the plane, and the convex hull of them all (what lies under what the camera saw, down to the table, taken as
solid). Given in the plane's frame, moved along it to stand over the origin: the plane is z = 0 and its normal
+z, so a pick world's table stands in for it wherever the camera's or the robot's frame put the object. A convex
hull fills a mug's or a bowl's opening; it is what a planner can check a grasp against in simulation before it
moves (picks.shape_check), not the object."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, dot3
from onepiece_dist.core.frames import perpendicular

VOLUME_DECIMALS = 9  # m^3: a mass from the hull's volume the same on every CPU


@dataclass(frozen=True)
class CompletedShape:
    """``vertices`` (k, 3) of the hull (the plane's frame, its footprint's middle at the origin; m), its ``volume``
    (m^3), and ``to_plane`` (4, 4): the cloud's frame to that frame."""

    vertices: np.ndarray
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


def completed_shape(points: np.ndarray, plane: SupportPlane) -> CompletedShape | None:
    """The hull of the object's observed ``points`` (m, 3; the cloud less the plane) and their shadows on
    ``plane``, or None when they span no volume (fewer than 4 points, or all on one plane)."""
    from scipy.spatial import ConvexHull, QhullError

    to_plane = plane_frame(plane)
    local = np.asarray(points, dtype=np.float64) @ to_plane[:3, :3].T + to_plane[:3, 3]
    local = local[local[:, 2] > 0]
    if len(local) < 4:
        return None
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
    return CompletedShape(both[hull.vertices], round(float(hull.volume), VOLUME_DECIMALS), to_plane)
