"""Force closure and wrench-space quality of two-finger grasps on a mesh: the labels PointNetGPD, graspnetAPI
and Dex-Net use (docs/trials.md, Analytic labels).

**Contacts.** At a pose, each finger pad starts fully open and closes along the closing axis until it meets the
mesh: rays from a grid of points over the pad's face (u over the finger's length, t over its height), cast with
``core.raycast`` (the same bits on every CPU). A pad's contact is the centroid of its hits within PAD_COMPLIANCE of
its nearest one, with the mean of their normals: a face meets the pad as a patch, not at whichever ray a rounding
makes nearest, and a jaw tilted by a hundredth of a radian still meets a face across it, not at a corner. A pad
that meets nothing is state "missing"; two pads meeting at one point (closer than ONE_POINT) are "one_point".
Neither is dropped: their scores are the stated values below.

**Force closure** (Nguyen's test for two contacts, as dex-net's ``PointGraspMetrics3D.force_closure``): with
unoriented normals, the grasp is in force closure at friction mu when the angle between each contact's normal line
and the line joining the contacts is at most arctan(mu). ``required_friction`` is the smallest such mu (the larger
tangent of the two angles); ``smallest_level`` picks the smallest mu of a list that holds, +inf where none does
(and for every state but "two").

**Ferrari-Canny L1 epsilon**: each contact's friction cone as ``facets`` edge forces of unit normal component,
each with its torque about the contacts' midpoint scaled by 1 / TORQUE_LENGTH; with soft fingers (the default)
also the torsional moments +-mu * TORSION_RADIUS about the normal. Epsilon is the distance from the origin to the
boundary of the hull of these wrenches (scipy's qhull), 0 when the origin is not strictly inside. Two point
contacts never resist a torque about their line, so their epsilon is always 0. Torques are about the midpoint,
not the object's centre of mass, and scaled by a fixed length: the score is a function of the contacts alone, so
a patch of the one object scores as its source object did.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.frames import apply_rotation, perpendicular, perturb_poses
from onepiece_dist.core.portable import sin_cos
from onepiece_dist.core.raycast import cast_rays, cross, dot

CONTACT_STATES = ("two", "missing", "one_point")
ONE_POINT = 1e-4  # m: two contacts closer than this are one
PAD_COMPLIANCE = 1e-3  # m: a pad's hits this much beyond its nearest one still touch it
TORQUE_LENGTH = 0.04  # m: torques are divided by this (the default gripper's half opening)
TORSION_RADIUS = 0.005  # m: a soft finger's torsional moment per unit normal force is mu times this
GRASPNET_LEVELS = (1.2, 1.0, 0.8, 0.6, 0.4, 0.2)  # graspnetAPI's force-closure sweep
POINTNETGPD_LEVELS = (2.0, 1.6, 1.2, 0.8, 0.5, 0.45, 0.4)  # PointNetGPD's full sweep (its default: 2.0, 1.6, 0.6)


@dataclass(frozen=True)
class Contacts:
    """points (n, 2, 3) and normals (n, 2, 3) unit, object frame, for the pad at -v then the pad at +v;
    state (n,) int8 index into CONTACT_STATES (points and normals are 0 where a pad met nothing); approach
    (n, 3) the gripper's u axis, which orients the friction cones' facets (so scores turn with the grasp)."""

    points: np.ndarray
    normals: np.ndarray
    state: np.ndarray
    approach: np.ndarray | None = None


def pad_contacts(vertices: np.ndarray, faces: np.ndarray, poses: np.ndarray, max_opening: float,
                 finger_length: float, finger_height: float, grid: tuple[int, int] = (5, 3)) -> Contacts:
    """Where each pad of the gripper at ``poses`` (n, 4, 4) first meets the mesh when it closes from
    ``max_opening`` (see the module's docstring). ``grid``: rays along u and t per pad."""
    poses = np.asarray(poses, dtype=np.float64)
    u = (np.arange(grid[0]) + 0.5) / grid[0] * finger_length
    t = ((np.arange(grid[1]) + 0.5) / grid[1] - 0.5) * finger_height
    pad = np.stack(np.meshgrid(u, t, indexing="ij"), axis=-1).reshape(-1, 2)  # (r, 2) u, t
    r = len(pad)
    local = np.zeros((2, r, 3))
    local[:, :, 0], local[:, :, 2] = pad[:, 0], pad[:, 1]
    local[0, :, 1], local[1, :, 1] = -max_opening / 2, max_opening / 2
    rot = poses[:, None, None, :3, :3]
    origins = apply_rotation(rot, local[None]) + poses[:, None, None, :3, 3]  # (n, 2, r, 3)
    closing = poses[:, :3, 1]
    directions = np.broadcast_to(np.stack([closing, -closing], axis=1)[:, :, None], origins.shape)
    hits = cast_rays(vertices, faces, origins.reshape(-1, 3), directions.reshape(-1, 3))
    dist = np.where(hits.t <= max_opening, hits.t, np.inf).reshape(len(poses), 2, r)
    nearest = dist.min(axis=2)
    found = np.isfinite(nearest)
    touching = np.isfinite(dist) & (dist <= (nearest + PAD_COMPLIANCE)[..., None])  # (n, 2, r)
    weight = touching / np.maximum(touching.sum(axis=2, keepdims=True), 1)
    ends = origins + directions * np.where(touching, dist, 0.0)[..., None]
    points = np.sum(weight[..., None] * ends, axis=2)
    normal = hits.normal.reshape(len(poses), 2, r, 3)
    normal = np.where((dot(normal, directions) < 0)[..., None], -normal, normal)  # all facing the pad's travel
    normal = np.sum(weight[..., None] * normal, axis=2)
    normal = normal / np.maximum(np.sqrt(dot(normal, normal)), 1e-300)[..., None]
    state = np.where(found.all(axis=1), 0, 1).astype(np.int8)
    gap = points[:, 1] - points[:, 0]
    state[(state == 0) & (np.sqrt(dot(gap, gap)) < ONE_POINT)] = 2
    return Contacts(np.where(found[..., None], points, 0.0), np.where(found[..., None], normal, 0.0), state,
                    poses[:, :3, 0].copy())


def required_friction(contacts: Contacts) -> np.ndarray:
    """(n,) float64 the smallest mu at which each grasp is in force closure (Nguyen, unoriented normals):
    max over its contacts of tan(angle between the normal line and the contact line); +inf unless state "two"."""
    line = contacts.points[:, 1] - contacts.points[:, 0]
    length = np.sqrt(dot(line, line))
    unit = line / np.maximum(length, 1e-300)[:, None]
    cos = np.minimum(np.abs(dot(contacts.normals[:, 0], unit)), np.abs(dot(contacts.normals[:, 1], unit)))
    cos = np.minimum(cos, 1.0)
    with np.errstate(divide="ignore"):
        tangent = np.where(cos > 0, np.sqrt(np.maximum(1 - cos * cos, 0.0)) / np.where(cos > 0, cos, 1.0), np.inf)
    return np.where(contacts.state == 0, tangent, np.inf)


def smallest_level(required: np.ndarray, levels: tuple[float, ...] = GRASPNET_LEVELS,
                   slack: float = 1e-9) -> np.ndarray:
    """(n,) float64 the smallest mu of ``levels`` at which each grasp is in force closure (required <= mu, with
    ``slack`` for a face-to-face grasp computed at exactly a level), +inf where none is."""
    ordered = np.sort(np.asarray(levels, dtype=np.float64))
    index = np.searchsorted(ordered, np.asarray(required) - slack, side="left")
    return np.where(index < len(ordered), ordered[np.minimum(index, len(ordered) - 1)], np.inf)


def contact_wrenches(contacts: Contacts, mu: float | np.ndarray, facets: int = 8, soft: bool = True) -> np.ndarray:
    """(n, 2 * (facets + 2 soft), 6) each grasp's contact wrench generators (module docstring), forces first,
    torques about the contacts' midpoint over TORQUE_LENGTH; normals turned to point at the other contact. ``mu``:
    one friction for every grasp, or (n,) one each."""
    p, n = contacts.points, contacts.normals
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (len(p),))[:, None, None, None]
    centre = p.mean(axis=1, keepdims=True)
    towards = (p[:, ::-1] - p)  # each contact to the other
    n = np.where((dot(n, towards) < 0)[..., None], -n, n)
    reference = perpendicular(n.reshape(-1, 3)).reshape(n.shape)
    if contacts.approach is not None:  # the approach on each contact's tangent plane, where it has a part there
        along = np.broadcast_to(contacts.approach[:, None], n.shape)
        along = along - dot(along, n)[..., None] * n
        size = np.sqrt(dot(along, along))[..., None]
        reference = np.where(size > 1e-9, along / np.maximum(size, 1e-300), reference)
    t1 = reference
    t2 = cross(n, t1)
    angles = 2 * np.pi * np.arange(facets) / facets
    sin, cos = sin_cos(angles)
    forces = n[:, :, None] + mu * (cos[:, None] * t1[:, :, None] + sin[:, None] * t2[:, :, None])  # (n,2,k,3)
    arm = (p - centre)[:, :, None]
    torques = cross(np.broadcast_to(arm, forces.shape), forces) / TORQUE_LENGTH
    wrenches = [np.concatenate([forces, torques], axis=-1)]
    if soft:
        twist = mu[:, :, 0] * TORSION_RADIUS / TORQUE_LENGTH
        base = cross(arm[:, :, 0], n) / TORQUE_LENGTH
        for sign in (1.0, -1.0):
            wrenches.append(np.concatenate([n, base + sign * twist * n], axis=-1)[:, :, None])
    return np.concatenate(wrenches, axis=2).reshape(len(p), -1, 6)


def ferrari_canny(contacts: Contacts, mu: float | np.ndarray, facets: int = 8, soft: bool = True) -> np.ndarray:
    """(n,) float64 the Ferrari-Canny L1 epsilon of each grasp at friction ``mu`` (one, or (n,) one each): the
    distance from the origin to the boundary of its contact wrenches' hull, 0 where the origin is not strictly
    inside (and for every state but "two")."""
    wrenches = contact_wrenches(contacts, mu, facets, soft)
    out = np.zeros(len(wrenches))
    for k in np.flatnonzero(contacts.state == 0):
        offsets = hull_offsets(wrenches[k])
        if offsets is not None:
            out[k] = max(float(-offsets.max()), 0.0)
    return out


def hull_offsets(points: np.ndarray) -> np.ndarray | None:
    """The offsets of the facets of the convex hull of ``points`` (k, 6), None where the hull is flat. Qhull
    without pre-merging ('Q0', a third of the default's time on these hulls, the same facets where it succeeds),
    else with its defaults where Q0 reports a precision problem."""
    from scipy.spatial import ConvexHull, QhullError

    for options in ("Q0", None):
        try:
            return ConvexHull(points, qhull_options=options).equations[:, -1]
        except QhullError:
            continue  # Q0: a precision problem, try merging; the defaults: flat (two point contacts)
    return None


def robust_scores(vertices: np.ndarray, faces: np.ndarray, poses: np.ndarray, rng: np.random.Generator,
                  mu: float = 0.5, samples: int = 25, gripper_shift: float = 0.005, object_shift: float = 0.01,
                  object_turn: float = 0.01, friction_sigma: float = 0.1, **pad) -> tuple[np.ndarray, np.ndarray]:
    """Dex-Net's robust epsilon: over ``samples`` perturbations of each pose (gripper moved by Gaussian noise of
    ``gripper_shift`` m, the object by ``object_shift`` m and turned by ``object_turn`` rad, friction mu with
    relative sigma ``friction_sigma``, drawn per grasp and sample), the mean epsilon and the share in force
    closure; every sample's contacts found in one call. ``pad``: the gripper's max_opening, finger_length,
    finger_height. -> (n,) mean epsilon, (n,) probability of force closure"""
    n = len(poses)
    moved = perturb_poses(np.tile(np.asarray(poses, dtype=np.float64), (samples, 1, 1)), rng,
                          np.hypot(gripper_shift, object_shift), object_turn)
    friction = np.maximum(mu * (1 + friction_sigma * rng.normal(size=samples * n)), 1e-3)
    contacts = pad_contacts(vertices, faces, moved, **pad)
    eps = ferrari_canny(contacts, friction).reshape(samples, n)
    closed = (required_friction(contacts) <= friction).reshape(samples, n)
    return eps.mean(axis=0), closed.mean(axis=0)


def closure_arrays(vertices: np.ndarray, faces: np.ndarray, poses: np.ndarray, spec) -> dict[str, np.ndarray]:
    """The dataset's closure arrays (fc_mu, fc_epsilon, fc_contacts) of grasps at ``poses`` (n, 4, 4) on the mesh,
    for a JobSpec ``spec`` (its gripper and closure fields)."""
    g, c = spec.gripper, spec.closure
    contacts = pad_contacts(vertices, faces, poses, g.max_opening, g.finger_length, g.finger_height)
    return {"fc_mu": smallest_level(required_friction(contacts), c.levels),
            "fc_epsilon": ferrari_canny(contacts, c.epsilon_mu, c.facets, c.soft), "fc_contacts": contacts.state}


def binary_label(closure, physics: np.ndarray | None, fc_mu: np.ndarray) -> np.ndarray:
    """(n,) uint8 a job's binary label under ``closure.label`` (a ClosureSpec): force closure at
    ``closure.good_mu`` or better, and with "both" the trials' outcome ``physics`` too (None: no trials ran)."""
    good = np.asarray(fc_mu) <= closure.good_mu + 1e-9
    if closure.label == "both" and physics is not None:
        good &= np.asarray(physics).astype(bool)
    return good.astype(np.uint8)
