"""Grasp candidate samplers: antipodal (rays cast along the inward normal, core.raycast) and the paper's normal one.

Both are deterministic for a given object content id and seed, vectorized, and reject poses whose palm or
fingers (fully open) would intersect the object.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.frames import compose_rotations, gripper_frame_batches, perpendicular, pose_from_axes
from onepiece_dist.core.mesh import TriangleMesh
from onepiece_dist.core.portable import sin_cos
from onepiece_dist.core.raycast import cast_rays, import_open3d
from onepiece_dist.specs.job import GripperSpec, SamplerSpec

_RAY_START = 1e-5
_COLLISION_POINTS = 4000
COLLISION_CASCADE = (128, 1024)  # prefixes of the probe points tried before all of them


@dataclass(frozen=True)
class GraspCandidates:
    """poses : (n, 4, 4) float64 gripper poses in the object frame; widths : (n,) float64 contact distance."""

    poses: np.ndarray
    widths: np.ndarray
    tried: int
    rejected_collision: int


def object_rng(content_id: str, seed: int, stream: int = 0) -> np.random.Generator:
    """Generator seeded by the object's content id, the job seed and a stream number."""
    return np.random.default_rng([int(content_id[:16], 16), int(content_id[16:32] or "0", 16), seed, stream])


def sample_candidates(mesh: TriangleMesh, points: np.ndarray, normals: np.ndarray, count: int,
                      gripper: GripperSpec, sampler: SamplerSpec, rng: np.random.Generator) -> GraspCandidates:
    """Up to ``count`` collision-free candidates by ``sampler.method``.

    points, normals : (m, 3) float64 dense surface samples of ``mesh`` with their normals
    """
    if sampler.method == "antipodal":
        poses, widths = _antipodal_poses(mesh, points, normals, count, gripper, sampler, rng)
    else:
        poses, widths = _normal_poses(points, normals, count, gripper, sampler, rng)
    probe = points[rng.permutation(len(points))[:_COLLISION_POINTS]]
    order = rng.permutation(len(poses))
    kept: list[np.ndarray] = []
    tried = found = 0
    while found < count and tried < len(order):
        batch = order[tried:tried + max(2 * (count - found), 64)]
        free = batch[~collides(probe, poses[batch], gripper)]
        kept.append(free[: count - found])
        tried += len(batch)
        found += len(kept[-1])
    pick = np.sort(np.concatenate(kept)) if kept else np.zeros(0, dtype=np.int64)
    return GraspCandidates(poses[pick], widths[pick], tried, tried - found)


def _antipodal_poses(mesh, points, normals, count, gripper, sampler, rng):
    """Contact pairs by ray casting along -normal, friction-cone test, then K approach angles each."""
    seeds = rng.permutation(len(points))[: max(4 * count, 64)]
    p, n = points[seeds], normals[seeds]
    hits = cast_rays(mesh.vertices, mesh.faces, p - n * _RAY_START, -n)  # the same bits on every CPU
    t_hit, n_q = hits.t, hits.normal
    width = t_hit + _RAY_START
    cos_cone = 1.0 / np.sqrt(1.0 + sampler.friction_cone**2)  # cos(arctan(mu)), without a CPU-picked arctan
    ok = np.isfinite(t_hit) & (width >= sampler.min_width) & (width <= gripper.max_opening * 0.95)
    ok &= np.abs(np.sum(n_q * n, axis=1)) >= cos_cone
    p, n, width = p[ok], n[ok], width[ok]
    centre = p - n * (width[:, None] / 2)
    return _poses_around_axes(centre, -n, width, gripper, sampler, rng)


def _poses_around_axes(centre, closing, width, gripper, sampler, rng):
    """K approach directions around each closing axis; contact depth sampled in depth_range."""
    k = sampler.approach_angles
    e1 = perpendicular(closing)
    e2 = np.cross(closing, e1)
    angles = rng.random(len(centre))[:, None] * 2 * np.pi + np.arange(k)[None, :] * 2 * np.pi / k
    sin, cos = sin_cos(angles)
    approach = (cos[..., None] * e1[:, None] + sin[..., None] * e2[:, None]).reshape(-1, 3)
    lo, hi = sampler.depth_range
    depth = (lo + (hi - lo) * rng.random(len(approach))) * gripper.closing_depth
    origins = np.repeat(centre, k, axis=0) - approach * depth[:, None]
    return pose_from_axes(origins, approach, np.repeat(closing, k, axis=0)), np.repeat(width, k)


def _normal_poses(points, normals, count, gripper, sampler, rng):
    """The paper's sampler: approach along the inward point-cloud normal, random closing axis."""
    seeds = rng.permutation(len(points))[: max(4 * count, 64)]
    p = points[seeds]
    n = estimate_normals(points, p)
    approach = -n
    e1 = perpendicular(approach)
    e2 = np.cross(approach, e1)
    ang = rng.random(len(p))[:, None] * np.pi
    sin, cos = sin_cos(ang)
    closing = cos * e1 + sin * e2
    lo, hi = sampler.depth_range
    depth = (lo + (hi - lo) * rng.random(len(p))) * gripper.closing_depth
    poses = pose_from_axes(p - approach * depth[:, None], approach, closing)
    return poses, np.full(len(p), gripper.max_opening)


def estimate_normals(points: np.ndarray, query: np.ndarray, neighbours: int = 16) -> np.ndarray:
    """Unit normals at ``query`` (k, 3) from PCA of their nearest ``points`` (m, 3), pointing away from the
    centroid. -> (k, 3) float64"""
    o3d = import_open3d()

    tree = o3d.geometry.KDTreeFlann(o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)))
    idx = np.array([np.asarray(tree.search_knn_vector_3d(q, neighbours)[1]) for q in query])
    normal = plane_normals(points[idx] - points[idx].mean(axis=1, keepdims=True))
    outward = np.sum(normal * (query - points.mean(axis=0)), axis=1) < 0
    return np.where(outward[:, None], -normal, normal)


def plane_normals(local: np.ndarray) -> np.ndarray:
    """Unit normals, sign arbitrary, of the least-squares planes of centred neighbourhoods ``local`` (k, q, 3)
    float: each covariance's least axis. -> (k, 3) float64

    The same bits on every CPU, unlike an SVD (LAPACK on the CPU's BLAS kernel): the covariance's adjugate has
    the eigenvalues l2*l3, l1*l3, l1*l2 on the same axes, so its powers (seven squarings: the 128th) turn every row
    onto the least axis, in products and sums of one fixed order. A neighbourhood on a line or a point (adjugate
    zero) gets an axis perpendicular to it.
    """
    cov = np.sum(local[:, :, :, None] * local[:, :, None, :], axis=1)  # (k, 3, 3)
    power = np.stack([np.cross(cov[:, 1], cov[:, 2]), np.cross(cov[:, 2], cov[:, 0]),
                      np.cross(cov[:, 0], cov[:, 1])], axis=1)
    for _ in range(7):
        power = power / np.maximum(np.abs(power).max(axis=(1, 2)), 1e-300)[:, None, None]
        power = compose_rotations(power, power)
    rows = np.sum(power * power, axis=2)
    best, largest = power[np.arange(len(power)), np.argmax(rows, axis=1)], rows.max(axis=1)
    spread = cov[np.arange(len(cov)), np.argmax(np.sum(cov * cov, axis=2), axis=1)]
    fallback = perpendicular(np.where(np.any(spread != 0, axis=1, keepdims=True), spread, [[0.0, 0.0, 1.0]]))
    return np.where(largest[:, None] > 0, best / np.sqrt(np.maximum(largest, 1e-300))[:, None], fallback)


# The Franka hand's collision mesh (pybullet_data franka_panda/meshes/collision/hand.obj) bounds, in the hand's
# frame (panda.urdf: z approach, fingers along y): about 20 cm across the closing axis, where a box palm as wide as
# the stroke misses what the hand meets. tests/test_pick_labels.py reads the mesh and checks these.
FRANKA_HAND = "franka_panda"
FRANKA_HAND_BOUNDS = ((-0.0316, -0.104, -0.0259), (0.0316, 0.1004, 0.066))
FRANKA_FINGERTIP_Z = 0.11217  # m along the hand's z (core.hand_frames: our fingertips are the Panda's)


def franka_hand_box(gripper: GripperSpec) -> np.ndarray:
    """(2, 3) the Franka hand's bounds in our gripper frame: u = z - (tip - finger_length), v = y, t = -x."""
    (x0, y0, z0), (x1, y1, z1) = FRANKA_HAND_BOUNDS
    shift = FRANKA_FINGERTIP_Z - gripper.finger_length
    return np.array([[z0 - shift, y0, -x1], [z1 - shift, y1, -x0]])


def gripper_boxes(gripper: GripperSpec, opening: float | None = None) -> np.ndarray:
    """Palm and finger boxes in the gripper frame at ``opening`` (default: fully open), and for the Franka hand
    (``gripper.name`` franka_panda, the panda preset) the hand's own bounds as a fourth box.

    returns : (3 or 4, 2, 3) float64, boxes x (lower, upper) x (u, v, t)
    """
    half = (gripper.max_opening if opening is None else opening) / 2
    f = gripper.finger_thickness
    fl, fh = gripper.finger_length, gripper.finger_height / 2
    palm = [[-gripper.palm_depth, -half - f, -gripper.palm_height / 2], [0.0, half + f, gripper.palm_height / 2]]
    left = [[0.0, -half - f, -fh], [fl, -half, fh]]
    right = [[0.0, half, -fh], [fl, half + f, fh]]
    boxes = np.array([palm, left, right])
    return np.concatenate([boxes, franka_hand_box(gripper)[None]]) if gripper.name == FRANKA_HAND else boxes


def collides(points: np.ndarray, poses: np.ndarray, gripper: GripperSpec) -> np.ndarray:
    """(n,) bool: does any of the (m, 3) object points lie inside the open gripper at each pose?

    A cascade, exact: the first COLLISION_CASCADE[0] points are tried on every pose, and only the poses they leave
    free meet the next, larger prefix (a pose that meets a point of a prefix meets one of the whole set; the probe
    points are in random order, so a small prefix already finds most collisions)."""
    hit, boxes = np.zeros(len(poses), dtype=bool), gripper_boxes(gripper)
    undecided = np.arange(len(poses))
    for size in (*COLLISION_CASCADE, len(points)):
        found = _collides_all(points[:size], poses[undecided], boxes)
        hit[undecided[found]] = True
        undecided = undecided[~found]
        if size >= len(points) or len(undecided) == 0:
            break
    return hit


def _collides_all(points: np.ndarray, poses: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    hit = np.zeros(len(poses), dtype=bool)
    for start, (u, v, t) in gripper_frame_batches(points, poses, pairs=100_000):  # the fastest here
        inside = np.zeros(u.shape, dtype=bool)
        for lower, upper in boxes:
            inside |= (u >= lower[0]) & (u < upper[0]) & (v >= lower[1]) & (v < upper[1]) & (t >= lower[2]) & (
                t < upper[2])
        hit[start:start + len(u)] = inside.any(axis=1)
    return hit
