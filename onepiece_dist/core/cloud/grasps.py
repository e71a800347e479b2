"""Grasp candidates on an observed point cloud (what one depth camera sees), as GPD and PointNetGPD sample them
(docs/planning.md): normals and a local frame from each sampled point's neighbourhood, approach directions turned
about the local curvature axis, the hand pushed in from a shallow bite while it stays clear of the cloud; poses
whose open gripper meets an observed point, or a support plane, are dropped.

Pure numpy (scipy's exact k-d tree for neighbours), the same bits on every CPU: normals and curvature axes come
from :func:`core.sampling.plane_normals`, rotations from fixed-order products.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.frames import apply_rotation, closing_region_bounds, in_box, pose_from_axes, to_gripper_frame
from onepiece_dist.core.portable import sin_cos
from onepiece_dist.core.sampling import collides, gripper_boxes, plane_normals
from onepiece_dist.core.spatial import box_corners
from onepiece_dist.specs.job import GripperSpec

NEIGHBOURS = 16  # points in a normal's neighbourhood
CURVATURE_NEIGHBOURS = 32  # normals in a curvature axis's neighbourhood
INITIAL_BITE = 0.01  # m of the object between the fingertips at the shallowest placement (GPD's init_bite)
BITE_STEP = 0.005  # m the hand is pushed in per step (GPD's deepenHand)
PLACEMENTS = (0.0, -0.5, 0.5, -0.25, 0.25)  # lateral hand shifts, as shares of half the opening
PLANE_CLEARANCE = 0.008  # m every gripper box corner keeps above a support plane (PlanSpec.table_clearance's)
ROUNDING = 1e-9  # m: far above a computed distance's rounding (about 1e-15 m here)


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products over the last axis of (..., 3) arrays, in one fixed order of products and sums: a matrix
    product would leave the last bits (and which points lie within a tolerance) to the CPU's BLAS kernel."""
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


@dataclass(frozen=True)
class SupportPlane:
    """A plane ``normal . x + offset = 0`` (unit normal towards the objects on it); ``inliers`` (m,) bool marks
    the cloud points that lie on it; ``noise``: the depth noise's deviation (m) measured under it where the
    planner took that noise out (core.cloud.denoise), else 0."""

    normal: np.ndarray
    offset: float
    inliers: np.ndarray
    noise: float = 0.0

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (..., ) of points (..., 3) above the plane."""
        return dot3(points, self.normal) + self.offset


@dataclass(frozen=True)
class CloudCandidates:
    """poses (n, 4, 4) float64 gripper poses in the cloud's frame; the counts say where the tried poses went:
    ``sampled`` placements tried, ``below_plane`` met the support plane at the shallowest bite of some lateral
    shift, ``collided`` the rest that met an observed point at every shift (the planner counts those with too few
    points in the closing region)."""

    poses: np.ndarray
    sampled: int
    collided: int
    below_plane: int


def voxel_downsample(points: np.ndarray, cell: float) -> np.ndarray:
    """(k,) int64 indices of one point per occupied cubic cell of edge ``cell`` (the first in point order),
    sorted. points (m, 3) float."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    keys = np.floor(points / cell).astype(np.int64)
    keys -= keys.min(axis=0)
    span = keys.max(axis=0) + 1
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**62:  # one int64 per cell: a 1-D unique, 10x faster
        keys = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
        _, first = np.unique(keys, return_index=True)
    else:
        _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def neighbour_indices(points: np.ndarray, query: np.ndarray, count: int) -> np.ndarray:
    """(k, count) int64: the ``count`` nearest of ``points`` (m, 3) to each of ``query`` (k, 3) (exact k-d tree;
    fewer points than ``count`` repeat the farthest)."""
    from scipy.spatial import cKDTree

    count = max(1, min(count, len(points)))
    _, idx = cKDTree(points).query(query, k=count)
    return np.asarray(idx, dtype=np.int64).reshape(len(query), count)


def cloud_normals(points: np.ndarray, query: np.ndarray, viewpoint: np.ndarray | None) -> np.ndarray:
    """(k, 3) unit normals at ``query`` (k, 3) from their NEIGHBOURS nearest ``points`` (m, 3), facing the camera
    at ``viewpoint`` (3,) (what it sees faces it), or, with no viewpoint, away from the cloud's centroid."""
    near = points[neighbour_indices(points, query, NEIGHBOURS)]
    normal = plane_normals(near - near.mean(axis=1, keepdims=True))
    towards = (np.asarray(viewpoint, dtype=np.float64) if viewpoint is not None else points.mean(axis=0)) - query
    flip = np.sum(normal * towards, axis=1) < 0
    if viewpoint is None:
        flip = ~flip
    return np.where(flip[:, None], -normal, normal)


def curvature_axes(points: np.ndarray, normals: np.ndarray, query: np.ndarray, query_normals: np.ndarray
                   ) -> np.ndarray:
    """(k, 3) unit axes along which the surface bends least at ``query`` (GPD's curvature axis): the least axis of
    the sum of n n^T over the CURVATURE_NEIGHBOURS nearest points' ``normals``, made perpendicular to the query's
    normal (a cylinder's axis on a cylinder)."""
    near = normals[neighbour_indices(points, query, CURVATURE_NEIGHBOURS)]
    axis = plane_normals(near)
    axis = axis - np.sum(axis * query_normals, axis=1, keepdims=True) * query_normals
    length = np.linalg.norm(axis, axis=1, keepdims=True)
    fallback = np.cross(query_normals, np.where(np.abs(query_normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    axis = np.where(length > 1e-9, axis / np.maximum(length, 1e-300), fallback)
    return axis / np.linalg.norm(axis, axis=1, keepdims=True)


def hand_frames(centres: np.ndarray, normals: np.ndarray, axes: np.ndarray, orientations: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Approach and closing directions turned about each curvature axis: ``orientations`` angles spread over
    (-90, 90) degrees from straight at the surface (approach = -normal). -> (centres, approach, closing), each
    (k * orientations, 3), point-major."""
    binormal = np.cross(normals, axes)
    angles = -np.pi / 2 + (np.arange(orientations) + 0.5) * np.pi / orientations
    sin, cos = sin_cos(angles)
    approach = -normals[:, None] * cos[None, :, None] + binormal[:, None] * sin[None, :, None]
    closing = binormal[:, None] * cos[None, :, None] + normals[:, None] * sin[None, :, None]
    return np.repeat(centres, orientations, axis=0), approach.reshape(-1, 3), closing.reshape(-1, 3)


def bite_depths(gripper: GripperSpec) -> np.ndarray:
    """Where the sampled point sits along u, shallowest bite first: from INITIAL_BITE short of the fingertips to
    the palm, in BITE_STEP steps."""
    first = gripper.finger_length - INITIAL_BITE
    return first - BITE_STEP * np.arange(int(np.floor(first / BITE_STEP)) + 1)


def _poses_at(centres: np.ndarray, approach: np.ndarray, closing: np.ndarray, depth: float) -> np.ndarray:
    return pose_from_axes(centres - approach * depth, approach, closing)


@dataclass(frozen=True)
class Blockers:
    """What an open gripper must stay clear of: the observed ``points`` (m, 3) and a support ``plane`` (or None),
    which every corner of its boxes keeps ``clearance`` (m) above. ``high`` holds the points more than
    ``clearance`` above the plane (less ROUNDING), the only ones a gripper above the plane can meet: its boxes are
    convex and every corner lies ``clearance`` above it. Poses above the plane are tried on those alone, the same
    answer from a fraction of the pairs (most of a view is its table)."""

    points: np.ndarray
    plane: SupportPlane | None
    high: np.ndarray
    clearance: float = PLANE_CLEARANCE

    @classmethod
    def of(cls, points: np.ndarray, plane: SupportPlane | None, clearance: float = PLANE_CLEARANCE) -> Blockers:
        high = points if plane is None else points[plane.distance(points) > clearance - ROUNDING]
        return cls(points, plane, high, clearance)

    def blocked(self, poses: np.ndarray, gripper: GripperSpec) -> tuple[np.ndarray, np.ndarray]:
        """(n,) bool above the plane and meeting a point, (n,) bool meeting a point or the plane. A pose that meets
        the plane is blocked either way and is not tried on the points (most of a view's points are its table's,
        and most blocked placements meet it)."""
        if self.plane is None:
            hit = collides(self.points, poses, gripper)
            return hit, hit
        above = above_plane(poses, gripper, self.plane, self.clearance)
        hit_points = np.zeros(len(poses), dtype=bool)
        hit_points[above] = collides(self.high, poses[above], gripper)
        return hit_points, hit_points | ~above


def deepest_free(blockers: Blockers, centres: np.ndarray, approach: np.ndarray, closing: np.ndarray,
                 gripper: GripperSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Push each hand in from the shallowest bite while its open gripper stays clear of the ``blockers``' points
    and above their plane: the pose at the last free bite (GPD's deepenHand); (n,) bool whether even the
    shallowest was free; (n,) bool whether the shallowest met the plane. Each deeper bite is checked only for the
    hands still free."""
    depths = bite_depths(gripper)
    poses = _poses_at(centres, approach, closing, depths[0])
    hit_points, hit = blockers.blocked(poses, gripper)
    free, below = ~hit, hit & ~hit_points
    going = np.flatnonzero(free)
    for depth in depths[1:]:
        if len(going) == 0:
            break
        deeper = _poses_at(centres[going], approach[going], closing[going], depth)
        clear = ~blockers.blocked(deeper, gripper)[1]
        poses[going[clear]] = deeper[clear]
        going = going[clear]
    return poses, free, below


def best_placement(points: np.ndarray, centres: np.ndarray, approach: np.ndarray, closing: np.ndarray,
                   gripper: GripperSpec, plane: SupportPlane | None = None, clearance: float = PLANE_CLEARANCE
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`deepest_free` at the first of PLACEMENTS lateral shifts of the hand along its closing axis (GPD's
    finger placements) whose shallowest bite is free (and ``clearance`` above ``plane``); hands no shift frees are
    tried at the next. Returns the poses, (n,) bool free at some shift, and (n,) bool not free and meeting the
    plane at some shift."""
    poses = np.zeros((len(centres), 4, 4))
    free, below = np.zeros(len(centres), bool), np.zeros(len(centres), bool)
    todo, blockers = np.arange(len(centres)), Blockers.of(points, plane, clearance)
    for shift in PLACEMENTS:
        if len(todo) == 0:
            break
        moved = centres[todo] + closing[todo] * (shift * gripper.max_opening / 2)
        found, ok, blocked = deepest_free(blockers, moved, approach[todo], closing[todo], gripper)
        poses[todo[ok]], free[todo[ok]] = found[ok], True
        below[todo] |= blocked
        todo = todo[~ok]
    return poses, free, below & ~free


def above_plane(poses: np.ndarray, gripper: GripperSpec, plane: SupportPlane,
                clearance: float = PLANE_CLEARANCE) -> np.ndarray:
    """(n,) bool: every corner of the open gripper's palm and fingers lies ``clearance`` (m) above ``plane``."""
    corners = np.concatenate([box_corners(lo, hi) for lo, hi in gripper_boxes(gripper)])  # (24, 3)
    world = apply_rotation(poses[:, None, :3, :3], corners[None]) + poses[:, None, :3, 3]
    return np.all(plane.distance(world) > clearance, axis=1)


def sample_cloud_grasps(cloud: np.ndarray, count: int, gripper: GripperSpec, rng: np.random.Generator,
                        viewpoint: np.ndarray | None = None, obstacles: np.ndarray | None = None,
                        plane: SupportPlane | None = None, orientations: int = 8,
                        clearance: float = PLANE_CLEARANCE) -> CloudCandidates:
    """Up to ``count`` collision-free candidates on ``cloud`` (m, 3) float, the object's observed points.

    obstacles : (q, 3) points the gripper must also stay clear of (a table's observed points), or None
    plane : a support plane every corner of the open gripper must stay ``clearance`` (m) above, or None
    Samples ``ceil(count / orientations)`` points, ``orientations`` approach directions each, the deepest free
    bite of each; keeps those free of every point and above the plane.
    """
    points = np.asarray(cloud, dtype=np.float64)
    if len(points) < NEIGHBOURS:
        return CloudCandidates(np.zeros((0, 4, 4)), 0, 0, 0)
    seeds = rng.permutation(len(points))[: -(-count // orientations)]
    all_normals = cloud_normals(points, points, viewpoint)  # row by row: the seeds' are among them
    normals = all_normals[seeds]
    axes = curvature_axes(points, all_normals, points[seeds], normals)
    centres, approach, closing = hand_frames(points[seeds], normals, axes, orientations)
    blockers = points if obstacles is None or len(obstacles) == 0 else np.vstack([points, obstacles])
    probe = blockers[rng.permutation(len(blockers))]  # random order: the collision cascade's prefixes find most
    poses, free, below = best_placement(probe, centres, approach, closing, gripper, plane, clearance)
    return CloudCandidates(poses[free][:count], len(centres), int(np.sum(~free & ~below)), int(below.sum()))


def fit_support_plane(points: np.ndarray, rng: np.random.Generator, up: np.ndarray | None = None,
                      tolerance: float = 0.004, iterations: int = 200, min_share: float = 0.15
                      ) -> SupportPlane | None:
    """The dominant plane of ``points`` (m, 3) by RANSAC (``iterations`` seeded draws of three points, inliers
    within ``tolerance`` m), or None when fewer than ``min_share`` of the points lie on it. The normal points
    along ``up`` (3,) when given, else towards the side that holds most of the other points (the objects)."""
    if len(points) < 3:
        return None
    triples = rng.integers(0, len(points), (iterations, 3))
    a, b, c = points[triples[:, 0]], points[triples[:, 1]], points[triples[:, 2]]
    normal = np.cross(b - a, c - a)
    length = np.linalg.norm(normal, axis=1)
    valid = length > 1e-12
    if not valid.any():
        return None
    normal, a = normal[valid] / length[valid, None], a[valid]
    counts = near_plane_counts(points, normal, a, tolerance)
    best = int(np.argmax(counts))
    if counts[best] < min_share * len(points):
        return None
    n, offset = _refined(points, np.abs(dot3(points - a[best], normal[best])) < tolerance)
    distance = dot3(points, n) + offset
    inliers = np.abs(distance) < tolerance
    side = dot3(np.asarray(up, dtype=np.float64), n) if up is not None else np.sum(np.sign(distance[~inliers]))
    if side < 0:
        n, offset = -n, -offset
    return SupportPlane(n, offset, inliers)


def near_plane_counts(points: np.ndarray, normals: np.ndarray, anchors: np.ndarray, tolerance: float) -> list[int]:
    """How many of ``points`` (m, 3) lie within ``tolerance`` of each plane through ``anchors[k]`` (k, 3) with unit
    normal ``normals[k]``: ``|dot3(points - anchor, normal)| < tolerance`` with the same bits, each operation on
    contiguous coordinate columns into buffers made once (a tenth of the time of (m, 3) temporaries a plane)."""
    x, y, z = (np.ascontiguousarray(points[:, axis], dtype=np.float64) for axis in range(3))
    distance, term, counts = np.empty(len(x)), np.empty(len(x)), []
    for n, p in zip(normals, anchors, strict=True):
        np.multiply(np.subtract(x, p[0], out=distance), n[0], out=distance)
        distance += np.multiply(np.subtract(y, p[1], out=term), n[1], out=term)
        distance += np.multiply(np.subtract(z, p[2], out=term), n[2], out=term)
        counts.append(int(np.count_nonzero(np.abs(distance, out=distance) < tolerance)))
    return counts


def _refined(points: np.ndarray, inliers: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares plane (unit normal, offset) of the ``inliers`` of ``points``: a three-point plane tilts
    with the depth buffer's millimetre steps."""
    chosen = points[inliers]
    centre = chosen.mean(axis=0)
    normal = plane_normals((chosen - centre)[None])[0]
    return normal, -float(dot3(normal, centre))


def suppress_near(poses: np.ndarray, scores: np.ndarray, gripper: GripperSpec, distance: float = 0.01,
                  angle_deg: float = 30.0, keep: int | None = None) -> np.ndarray:
    """Pose-distance non-maximum suppression: indices of ``poses`` (n, 4, 4) in order of ``scores`` (n,), best
    first, each kept only when every better kept pose is at least ``distance`` m away (closing-region centres) or
    turned by more than ``angle_deg`` (the gripper's 180-degree turn about its approach counts as the same pose).
    Stops at ``keep`` poses."""
    order = np.argsort(-np.asarray(scores), kind="stable")
    centres = poses[:, :3, 3] + poses[:, :3, 0] * gripper.closing_depth / 2
    cos_limit = float(sin_cos(np.array([angle_deg * np.pi / 180]))[1][0])
    kept: list[int] = []
    for i in order:
        if kept:
            gap = centres[kept] - centres[i]
            near = np.sqrt(dot3(gap, gap)) < distance
            same_u = np.sum(poses[kept, :3, 0] * poses[i, :3, 0], axis=1) > cos_limit
            same_v = np.abs(np.sum(poses[kept, :3, 1] * poses[i, :3, 1], axis=1)) > cos_limit
            if np.any(near & same_u & same_v):
                continue
        kept.append(int(i))
        if keep is not None and len(kept) >= keep:
            break
    return np.array(kept, dtype=np.int64)


def antipodal_scores(points: np.ndarray, normals: np.ndarray, poses: np.ndarray, gripper: GripperSpec,
                     min_points: int = 1) -> np.ndarray:
    """An analytic score of each pose (n, 4, 4) from the observed ``points`` (m, 3) and their ``normals``: the
    contacts are the points inside the closing region nearest each finger (the largest and the smallest v); the
    score is the smaller cosine between a contact's normal and the line joining the contacts (1: antipodal, so
    force closure at any friction; force closure at friction mu when it is at least 1 / sqrt(1 + mu^2)). 0 when
    fewer than ``min_points`` points are inside."""
    lower, upper = closing_region_bounds(gripper.closing_depth, gripper.closing_width, gripper.closing_height)
    scores = np.zeros(len(poses))
    for k, pose in enumerate(poses):
        local = to_gripper_frame(points, pose[None])[0]
        inside = np.flatnonzero(in_box(local, lower, upper))
        if len(inside) < max(min_points, 1):
            continue
        right, left = inside[np.argmax(local[inside, 1])], inside[np.argmin(local[inside, 1])]
        line = points[right] - points[left]
        norm = float(np.sqrt(dot3(line, line)))
        if norm < 1e-6:
            continue
        line = line / norm
        scores[k] = min(abs(float(dot3(normals[right], line))), abs(float(dot3(normals[left], line))))
    return scores
