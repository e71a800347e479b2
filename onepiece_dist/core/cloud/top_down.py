"""The grasp a user tries first (issue 55's baseline): straight down along gravity onto the top of the observed
object, closing across its narrow horizontal axis. Pure geometry on the observed points, nothing learned.

Ranked: the narrow axis through the middle of the object's footprint, then its wide axis there, then the narrow
axis through the points' mean. The palm stops ``CLEARANCE`` above the top; an object lower than the fingers are
long is grasped with the fingertips ``CLEARANCE`` above its lowest point (the table).
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import dot3
from onepiece_dist.core.frames import pose_from_axes
from onepiece_dist.specs.job import GripperSpec

CLEARANCE = 0.005  # m


def horizontal_axes(down: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors that, with ``down`` (3,), make an orthonormal frame."""
    down = np.asarray(down, dtype=np.float64)
    helper = np.array([1.0, 0.0, 0.0]) if abs(down[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    first = helper - dot3(helper, down) * down
    first = first / np.sqrt(dot3(first, first))
    return first, np.cross(down, first)


def narrow_direction(xy: np.ndarray) -> tuple[float, float]:
    """The unit 2-D direction along which ``xy`` (m, 2) spreads least (the smaller principal axis, in closed form)."""
    centred = xy - xy.mean(axis=0)
    a, b, c = (np.mean(centred[:, 0] * centred[:, 0]), np.mean(centred[:, 0] * centred[:, 1]),
               np.mean(centred[:, 1] * centred[:, 1]))
    smaller = (a + c) / 2 - np.sqrt(((a - c) / 2) ** 2 + b * b)
    direction = np.array([b, smaller - a]) if abs(b) > 1e-12 else (
        np.array([1.0, 0.0]) if a <= c else np.array([0.0, 1.0]))
    direction = direction / np.sqrt(direction[0] ** 2 + direction[1] ** 2)
    return float(direction[0]), float(direction[1])


def top_down_grasps(points: np.ndarray, down: np.ndarray, gripper: GripperSpec) -> np.ndarray:
    """(3, 4, 4) ranked top-down poses (ours: u approach, v closing) on the object's observed ``points`` (m, 3),
    gravity ``down`` (3,) unit; (0, 4, 4) when fewer than 3 points."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 3:
        return np.zeros((0, 4, 4))
    down = np.asarray(down, dtype=np.float64)
    first, second = horizontal_axes(down)
    xy = np.stack([dot3(points, first), dot3(points, second)], axis=1)
    height = -dot3(points, down)
    palm = max(height.max(), height.min() + gripper.finger_length) + CLEARANCE
    middle = (xy.min(axis=0) + xy.max(axis=0)) / 2
    nx, ny = narrow_direction(xy)
    narrow = nx * first + ny * second
    wide = -ny * first + nx * second
    centres = [middle, middle, xy.mean(axis=0)]
    origins = np.array([c[0] * first + c[1] * second - palm * down for c in centres])
    return pose_from_axes(origins, np.repeat(down[None], 3, axis=0), np.array([narrow, wide, narrow]))
