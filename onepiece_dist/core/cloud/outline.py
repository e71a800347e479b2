"""What the object is outside the fingers (issue 55): a crop holds only the observed points inside the closing
region and the context only the object's centre, so a network cannot see the mug's body hanging off the rim it
grasps, nor how far a flat package reaches past the fingers. The outline is the observed object's shape seen from
each grasp: OUTLINE_POINTS of its points, spread over it by farthest-point sampling, in each gripper frame with the
closing region's centre at the origin.

The sample starts at the object's first point (the camera's raster order) and adds, each time, the point farthest
from those chosen; objects with fewer points repeat theirs. Fixed-order products only: the same bits on every
CPU.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import dot3
from onepiece_dist.core.grasp_context import closing_centres, transposed_rotation

OUTLINE_POINTS = 64
OUTLINE_MODELS = frozenset({"pointnet_context_outline"})  # the networks that read it (learn.models)


def _squared_distances(points: np.ndarray, point: np.ndarray) -> np.ndarray:
    d = points - point
    return dot3(d, d)


def farthest_points(points: np.ndarray, count: int = OUTLINE_POINTS) -> np.ndarray:
    """(count,) indices into ``points`` (m, 3): the farthest-point sample from the first point (cycled where m is
    smaller than ``count``; empty where m is 0)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) == 0:
        return np.zeros(0, np.int64)
    if len(points) <= count:
        return np.resize(np.arange(len(points)), count)
    chosen = np.zeros(count, np.int64)
    nearest = _squared_distances(points, points[0])
    for k in range(1, count):
        chosen[k] = int(np.argmax(nearest))
        nearest = np.minimum(nearest, _squared_distances(points, points[chosen[k]]))
    return chosen


def outline(points: np.ndarray, poses: np.ndarray, closing_depth: float, count: int = OUTLINE_POINTS) -> np.ndarray:
    """(n, count, 3) float32: the object's observed ``points`` (m, 3), their farthest-point sample, in the frame of
    each of ``poses`` (n, 4, 4) gripper-to-cloud, relative to its closing region's centre (m); zeros where the
    object has no points."""
    poses = np.asarray(poses, dtype=np.float64)
    if len(points) == 0 or len(poses) == 0:
        return np.zeros((len(poses), count, 3), np.float32)
    sample = np.asarray(points, dtype=np.float64)[farthest_points(points, count)]
    rel = sample[None, :, :] - closing_centres(poses, closing_depth)[:, None, :]  # (n, count, 3)
    rot = np.repeat(poses[:, :3, :3], count, axis=0)
    return transposed_rotation(rot, rel.reshape(-1, 3)).reshape(len(poses), count, 3).astype(np.float32)

__all__ = ["OUTLINE_MODELS", "OUTLINE_POINTS", "farthest_points", "outline"]
