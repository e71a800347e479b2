"""What a crop in the gripper frame cannot know (issue 55): where down is and where the observed object's centre
lies, both in the gripper frame. A crop alone cannot tell a grasp from above from one from the side, nor the lever
arm a lifted object hangs on; these six numbers can.

The context of a grasp, (6,) float32: gravity's unit direction in the gripper frame (u approach, v closing, w),
then the observed object's centre minus the closing region's centre, in the gripper frame (m). Down is the support
plane's normal turned over where a plane was found, else the cloud frame's -z. Fixed-order products only: the
same bits on every CPU.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import dot3

CONTEXT_SIZE = 6
WORLD_DOWN = np.array([0.0, 0.0, -1.0])


def transposed_rotation(rot: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``rot.T @ vector`` for (n, 3, 3) ``rot`` and (n, 3) or (3,) ``vectors``, in one fixed order of sums."""
    v = np.broadcast_to(np.asarray(vectors, dtype=np.float64), (len(rot), 3))
    return rot[:, 0, :] * v[:, 0, None] + rot[:, 1, :] * v[:, 1, None] + rot[:, 2, :] * v[:, 2, None]


def closing_centres(poses: np.ndarray, closing_depth: float) -> np.ndarray:
    """(n, 3) the closing region's centre of each of ``poses`` (n, 4, 4): half ``closing_depth`` along approach."""
    return poses[:, :3, 3] + poses[:, :3, 0] * (closing_depth / 2)


def grasp_context(poses: np.ndarray, centre: np.ndarray, down: np.ndarray, closing_depth: float,
                  eye: np.ndarray | None = None) -> np.ndarray:
    """(n, 6) float32 context of ``poses`` (n, 4, 4) gripper-to-cloud: ``down`` (3,) unit gravity and ``centre`` (3,)
    the observed object's centre (or each grasp's object's, (n, 3)), both in the cloud's frame, seen from each
    gripper frame. With the camera's position ``eye`` (3,), or each grasp's (n, 3): (n, 9), then the unit direction
    from the closing region's centre to the camera, in the gripper frame (which side of the crop was seen, which
    lies in occluded space)."""
    poses = np.asarray(poses, dtype=np.float64)
    width = CONTEXT_SIZE + (3 if eye is not None else 0)
    if len(poses) == 0:
        return np.zeros((0, width), np.float32)
    rot = poses[:, :3, :3]
    closing_centre = closing_centres(poses, closing_depth)
    gravity = transposed_rotation(rot, down)
    centre = np.asarray(centre, dtype=np.float64)
    offset = transposed_rotation(rot, (centre if centre.ndim == 2 else centre[None]) - closing_centre)
    parts = [gravity, offset]
    if eye is not None:
        towards = np.asarray(eye, dtype=np.float64) - closing_centre
        length = np.sqrt(dot3(towards, towards))
        parts.append(transposed_rotation(rot, towards / np.maximum(length, 1e-12)[:, None]))
    return np.concatenate(parts, axis=1).astype(np.float32)


def object_centre(points: np.ndarray) -> np.ndarray:
    """(3,) the observed object's centre: the middle of its points' bounding box (no sum: the same on every CPU,
    and less pulled towards the side the camera sees most of)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) == 0:
        return np.zeros(3)
    return (points.min(axis=0) + points.max(axis=0)) / 2
