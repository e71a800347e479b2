"""The one gripper-frame convention (docs/gripper_frame.md).

A gripper pose is a (4, 4) float64 homogeneous transform from the gripper frame to the object frame.
Its rotation columns are the gripper axes expressed in the object frame: column 0 = u (approach,
palm to fingertips), column 1 = v (closing axis), column 2 = t = u x v (finger height).
The origin is the palm centre. The closing region is 0 <= u < depth, |v| < width/2, |t| < height/2.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.portable import sin_cos


def pose_from_axes(origins: np.ndarray, approach: np.ndarray, closing: np.ndarray) -> np.ndarray:
    """Build gripper poses.

    origins : (n, 3) float   palm centres in the object frame
    approach : (n, 3) float  u axes (need not be unit)
    closing : (n, 3) float   v axes; made orthogonal to u
    returns : (n, 4, 4) float64
    """
    u = _unit(np.asarray(approach, dtype=np.float64))
    v = np.asarray(closing, dtype=np.float64)
    v = _unit(v - np.sum(v * u, axis=1, keepdims=True) * u)
    t = np.cross(u, v)
    poses = np.zeros((len(u), 4, 4))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = u, v, t
    poses[:, :3, 3] = origins
    poses[:, 3, 3] = 1.0
    return poses


def invert_poses(poses: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms. poses : (..., 4, 4) -> (..., 4, 4)."""
    rot = np.swapaxes(poses[..., :3, :3], -1, -2)
    out = np.zeros_like(poses)
    out[..., :3, :3] = rot
    out[..., :3, 3] = -apply_rotation(rot, poses[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def to_gripper_frame(points: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Express object-frame points in each gripper frame, the same bits on every CPU (fixed-order products: a
    point on a voxel boundary, as on a box's face, must fall on the same side on every machine).

    points : (m, 3) float, poses : (n, 4, 4) float -> (n, m, 3) float64
    """
    rot = np.swapaxes(np.asarray(poses, dtype=np.float64)[:, :3, :3], -1, -2)  # rows: the gripper axes
    offset = apply_rotation(rot, poses[:, :3, 3])
    return apply_rotation(rot[:, None], np.asarray(points, dtype=np.float64)[None]) - offset[:, None, :]


def gripper_frame_batches(points: np.ndarray, poses: np.ndarray, pairs: int = 200_000):
    """Every point in every gripper frame, as contiguous coordinate planes, a batch of poses at a time (about
    ``pairs`` point-pose pairs each, so a batch stays in the cache). The same bits on every CPU and as
    :func:`to_gripper_frame`: each coordinate is ((r0 x + r1 y) + r2 z) - offset, every operation rounded on its
    own, where a matrix product would leave the last bits (and a point on a voxel boundary) to the BLAS kernel.

    points : (m, 3) float, poses : (n, 4, 4) float
    yields : (start, coords) with coords (3, k, m) float64, the u, v, t of each point in poses[start:start + k]
    """
    x, y, z = (np.ascontiguousarray(points[:, axis], dtype=np.float64) for axis in range(3))
    step = max(1, pairs // max(len(points), 1))
    for start in range(0, len(poses), step):
        rot = np.asarray(poses[start:start + step, :3, :3], dtype=np.float64)  # columns: the gripper axes
        offset = apply_rotation(np.swapaxes(rot, -1, -2), poses[start:start + step, :3, 3])  # (k, 3)
        coords = np.empty((3, len(rot), len(points)))
        term = np.empty((len(rot), len(points)))
        for axis in range(3):
            plane = coords[axis]
            np.multiply(rot[:, 0, axis, None], x, out=plane)
            plane += np.multiply(rot[:, 1, axis, None], y, out=term)
            plane += np.multiply(rot[:, 2, axis, None], z, out=term)
            plane -= offset[:, axis, None]
        yield start, coords


def rotate_points(points: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """``points @ rot`` with the same bits on every CPU: (m, 3) float, rot (3, 3) float -> (m, 3) float64.

    Each row's three products are summed in one fixed order, each operation rounded on its own. A matrix product
    goes to BLAS, whose kernel (chosen per CPU: AVX-512, AVX2 with FMA, SSE) changes the last bits; geometry that
    then decides by exact comparisons (the clip's plane and collinearity tests) changes with them, and so does the
    physics on it. Slower than BLAS: for per-object geometry, not for the crops' millions of point-pose pairs.
    """
    return apply_rotation(np.swapaxes(rot, -1, -2), points)


def apply_rotation(rot: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``rot @ vector`` for (..., 3, 3) ``rot`` and (..., 3) ``vectors`` (broadcast), the same bits on every CPU:
    three products summed in one fixed order, not a BLAS kernel. The one fixed-order product that rotate_points,
    compose_rotations and compose_poses are made of. -> (..., 3) float64"""
    r, v = np.asarray(rot, dtype=np.float64), np.asarray(vectors, dtype=np.float64)
    return r[..., :, 0] * v[..., 0, None] + r[..., :, 1] * v[..., 1, None] + r[..., :, 2] * v[..., 2, None]


def compose_rotations(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for (..., 3, 3) float matrices, the same bits on every CPU: ``a`` applied to each column of ``b``.
    -> (..., 3, 3) float64"""
    columns = apply_rotation(np.asarray(a)[..., None, :, :], np.swapaxes(b, -1, -2))  # (..., column, row)
    return np.swapaxes(columns, -1, -2)


def compose_poses(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for (..., 4, 4) rigid transforms (last row 0 0 0 1), the same bits on every CPU.
    -> (..., 4, 4) float64"""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    out[..., :3, :3] = compose_rotations(a[..., :3, :3], b[..., :3, :3])
    out[..., :3, 3] = apply_rotation(a[..., :3, :3], b[..., :3, 3]) + a[..., :3, 3]
    out[..., 3, 3] = 1.0
    return out


def transform_points(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Apply one (4, 4) transform to (m, 3) points, the same bits on every CPU. -> (m, 3) float64"""
    return apply_rotation(np.asarray(pose, dtype=np.float64)[:3, :3], points) + pose[:3, 3]


def in_box(points_g: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Mask of gripper-frame points with lower <= p < upper on every axis. (..., 3) -> (...) bool."""
    return np.all((points_g >= lower) & (points_g < upper), axis=-1)


def closing_region_bounds(depth: float, width: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners of the closing region in the gripper frame, each (3,) float64."""
    return np.array([0.0, -width / 2, -height / 2]), np.array([depth, width / 2, height / 2])


def perturb_pose(pose: np.ndarray, rng: np.random.Generator, translation: float, rotation: float) -> np.ndarray:
    """(4, 4) ``pose`` turned about a random axis (gripper frame) by a Gaussian angle of std ``rotation`` (rad)
    and moved by Gaussian noise of std ``translation`` (m) per axis: the one perturbation of label trials and of
    the label stage's poses around a placement."""
    axis = rng.normal(size=3)
    axis /= np.sqrt(np.sum(axis * axis))
    angle = rng.normal(0, rotation)
    out = pose.copy()
    out[:3, :3] = compose_rotations(pose[:3, :3], axis_turns(axis[None], np.array([angle]))[0])
    out[:3, 3] += rng.normal(0, translation, 3)
    return out


def axis_turns(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(m, 3, 3) the rotations by ``angle`` (m,) rad about unit ``axis`` (m, 3) (Rodrigues), the same bits on
    every CPU."""
    k = np.zeros((len(axis), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = axis[:, 2], -axis[:, 1], axis[:, 0]
    sin, cos = sin_cos(angle)
    return np.eye(3) + sin[:, None, None] * k + (1 - cos)[:, None, None] * compose_rotations(k, k)


def perturb_poses(poses: np.ndarray, rng: np.random.Generator, translation: float, rotation: float) -> np.ndarray:
    """(m, 4, 4) each of ``poses`` perturbed as :func:`perturb_pose` does, with every draw made at once (axes,
    then angles, then shifts): the same distribution, not the same draws."""
    poses = np.asarray(poses, dtype=np.float64)
    m = len(poses)
    axis = rng.normal(size=(m, 3))
    axis /= np.sqrt(np.sum(axis * axis, axis=1))[:, None]
    angle = rng.normal(0, rotation, m)
    out = poses.copy()
    out[:, :3, :3] = compose_rotations(poses[:, :3, :3], axis_turns(axis, angle))
    out[:, :3, 3] += rng.normal(0, translation, (m, 3))
    return out


def perpendicular(vectors: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each of (n, 3) vectors."""
    vectors = _unit(vectors)
    helper = np.where(np.abs(vectors[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    return _unit(np.cross(vectors, helper))


def _unit(vectors: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(norms > 0, norms, 1.0)


def quat_from_matrix(rot: np.ndarray) -> list[float]:
    """(3, 3) rotation -> quaternion [x, y, z, w] (pybullet's and ROS's order)."""
    m = rot
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = 0.25 * s, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    return [float(x) for x in q]


def matrix_from_quat(quaternion) -> np.ndarray:
    """Quaternion [x, y, z, w] (normalised here) -> (3, 3) rotation."""
    x, y, z, w = np.asarray(quaternion, dtype=np.float64) / np.sqrt(np.sum(np.square(quaternion)))
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
