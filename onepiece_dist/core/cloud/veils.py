"""Flying pixels taken out of a view (PlanSpec.veils; docs/picks.md). Where a pixel straddles an object's edge, a
stereo or time-of-flight camera reads a depth between the object and what lies behind it, so a veil of points
trails off every silhouette along the camera's rays. A veil's surface runs along the rays, where every surface the
camera sees faces it at some angle: a point whose local plane (its NEIGHBOURS nearest, core.cloud.grasps) turns
its normal to within VEIL_COSINE of square to the point's ray is dropped (the shadow-point test of laser and depth
filters). A real surface seen within about 10 degrees of grazing goes with it: few points, as the camera sees it.
Pure numpy and scipy's exact k-d tree, fixed-order products: the same bits on every CPU."""

from __future__ import annotations

import dataclasses

import numpy as np

from onepiece_dist.core.cloud.grasps import SupportPlane, cloud_normals, dot3

VEIL_COSINE = 0.2  # |normal . ray| below this: the local surface lies within 11.5 degrees of the ray


def veil_mask(points: np.ndarray, viewpoint: np.ndarray) -> np.ndarray:
    """(m,) bool: which of ``points`` (m, 3) lie on a veil seen from ``viewpoint`` (3,): their local plane runs
    along their ray (its normal within VEIL_COSINE of square to it)."""
    if len(points) < 3:
        return np.zeros(len(points), dtype=bool)
    rays = points - np.asarray(viewpoint, dtype=np.float64)
    rays = rays / np.maximum(np.sqrt(dot3(rays, rays)), 1e-12)[:, None]
    return np.abs(dot3(cloud_normals(points, points, viewpoint), rays)) < VEIL_COSINE


def without_veils(points: np.ndarray, plane: SupportPlane | None, viewpoint: np.ndarray
                  ) -> tuple[np.ndarray, SupportPlane | None]:
    """``points`` less the veils among those off ``plane`` (all of them without a plane; normals from those
    points alone: the table's are left as they are), and ``plane`` with its inliers kept in step."""
    off = np.ones(len(points), dtype=bool) if plane is None else ~plane.inliers
    veil = np.zeros(len(points), dtype=bool)
    veil[off] = veil_mask(points[off], viewpoint)
    kept = points[~veil]
    return kept, None if plane is None else dataclasses.replace(plane, inliers=plane.inliers[~veil])
