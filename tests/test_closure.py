"""core.closure on shapes whose answers are known: force closure's smallest friction and the Ferrari-Canny
epsilon, and the contacts they come from."""

import math

import numpy as np
import pytest

from onepiece_dist.core.clip import hull_mesh
from onepiece_dist.core.closure import (
    GRASPNET_LEVELS,
    POINTNETGPD_LEVELS,
    Contacts,
    contact_wrenches,
    ferrari_canny,
    pad_contacts,
    required_friction,
    robust_scores,
    smallest_level,
)
from onepiece_dist.core.frames import compose_poses, pose_from_axes
from onepiece_dist.core.mesh import box_mesh, sphere_mesh

PAD = {"max_opening": 0.08, "finger_length": 0.04, "finger_height": 0.02}


def top_down(centre_height: float, offset_t: float = 0.0) -> np.ndarray:
    """(1, 4, 4) a gripper above the origin approaching along -z, closing along x, its pads' middle at
    ``centre_height`` and moved by ``offset_t`` along its t axis (y)."""
    origin = np.array([[0.0, offset_t, centre_height + PAD["finger_length"] / 2]])
    return pose_from_axes(origin, np.array([[0.0, 0, -1]]), np.array([[1.0, 0, 0]]))


def wedge(half_angle: float, half_width: float = 0.015, half_height: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """A prism whose two side faces lean out by ``half_angle`` from vertical: x = +-(w + (z + h) tan)."""
    grow = 2 * half_height * math.tan(half_angle)
    corners = [[sx * (half_width + (grow if z > 0 else 0)), y, z] for sx in (-1, 1) for y in (-0.03, 0.03)
               for z in (-half_height, half_height)]
    return hull_mesh(np.array(corners))


def test_a_box_grasped_face_to_face_closes_at_the_smallest_level():
    box = box_mesh((0.04, 0.06, 0.06))
    contacts = pad_contacts(box.vertices, box.faces, top_down(0.01), **PAD)
    assert contacts.state.tolist() == [0]
    assert np.allclose(np.abs(contacts.points[0, :, 0]), 0.02)
    assert required_friction(contacts)[0] == pytest.approx(0.0, abs=1e-12)
    assert smallest_level(required_friction(contacts)).tolist() == [0.2]
    assert smallest_level(required_friction(contacts), POINTNETGPD_LEVELS).tolist() == [0.4]


@pytest.mark.parametrize("degrees", [10.0, 20.0, 30.0, 45.0])
def test_a_wedge_of_half_angle_theta_needs_tan_theta(degrees):
    theta = math.radians(degrees)
    vertices, faces = wedge(theta)
    contacts = pad_contacts(vertices, faces, top_down(0.0), **PAD)
    required = required_friction(contacts)[0]
    assert required == pytest.approx(math.tan(theta), rel=1e-9)
    level = smallest_level(np.array([required]))[0]
    assert level == min(mu for mu in GRASPNET_LEVELS if mu >= math.tan(theta) - 1e-12)


@pytest.mark.parametrize("offset", [0.0, 0.01, 0.02])
def test_a_sphere_through_and_off_its_centre(offset):
    radius = 0.03
    sphere = sphere_mesh(radius, rings=96, sectors=192)
    pad = {**PAD, "finger_height": 0.0}  # one row of rays, at the gripper's t = offset
    contacts = pad_contacts(sphere.vertices, sphere.faces, top_down(0.0, offset), grid=(5, 1), **pad)
    expected = offset / math.sqrt(radius**2 - offset**2)  # the radial normal against the chord at that height
    assert required_friction(contacts)[0] == pytest.approx(expected, abs=0.035)  # facets of under 2 degrees


def test_pads_that_meet_nothing_or_one_point_are_marked_not_dropped():
    box = box_mesh((0.04, 0.06, 0.06))
    poses = np.concatenate([top_down(0.01), top_down(0.2)])  # the second far above the box
    contacts = pad_contacts(box.vertices, box.faces, poses, **PAD)
    assert contacts.state.tolist() == [0, 1]
    assert required_friction(contacts)[1] == np.inf and smallest_level(required_friction(contacts))[1] == np.inf
    assert ferrari_canny(contacts, 0.5)[1] == 0.0 and not np.isnan(contacts.points).any()
    one = Contacts(np.zeros((1, 2, 3)), np.array([[[1.0, 0, 0], [-1.0, 0, 0]]]), np.array([2], dtype=np.int8))
    assert required_friction(one)[0] == np.inf and ferrari_canny(one, 0.5)[0] == 0.0


def antipodal(mu_normal_tilt: float = 0.0) -> Contacts:
    a = 0.02
    tilt = np.array([math.cos(mu_normal_tilt), 0.0, math.sin(mu_normal_tilt)])
    return Contacts(np.array([[[-a, 0, 0], [a, 0, 0]]]), np.array([[tilt, -tilt * [1, 1, -1]]]),
                    np.array([0], dtype=np.int8))


def test_epsilon_is_the_distance_to_the_wrench_hull_boundary_from_an_independent_support_function():
    """For a convex body holding the origin, the distance to its boundary is the least support value over unit
    directions: sampled directions give an upper bound that the hull's facets must meet from below, closely."""
    contacts = antipodal()
    eps = ferrari_canny(contacts, 0.5)[0]
    wrenches = contact_wrenches(contacts, 0.5)[0]
    directions = np.random.default_rng(0).normal(size=(400_000, 6))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    support = (directions @ wrenches.T).max(axis=1).min()
    assert 0 < eps <= support + 1e-12 and eps > 0.8 * support


def test_epsilon_grows_with_friction_and_two_point_contacts_hold_no_torque():
    contacts = antipodal()
    values = [ferrari_canny(contacts, mu)[0] for mu in (0.2, 0.5, 1.0)]
    assert values[0] < values[1] < values[2]
    assert ferrari_canny(contacts, 0.5, soft=False)[0] == 0.0
    assert ferrari_canny(antipodal(math.radians(40)), 0.5)[0] == 0.0  # outside the cone: no closure, no epsilon


def test_the_fast_hull_gives_the_default_hulls_epsilon_and_a_friction_per_grasp_scores_each_alone():
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(4)
    tilts = rng.uniform(0, math.radians(20), 30)
    contacts = Contacts(np.repeat(antipodal().points, 30, axis=0),
                        np.stack([antipodal(t).normals[0] for t in tilts]), np.zeros(30, dtype=np.int8),
                        np.tile([[0.0, 1.0, 0.0]], (30, 1)))
    mu = rng.uniform(0.3, 1.0, 30)
    eps = ferrari_canny(contacts, mu)
    wrenches = contact_wrenches(contacts, mu)
    default = [max(-ConvexHull(w).equations[:, -1].max(), 0.0) for w in wrenches]  # qhull with its defaults
    assert np.allclose(eps, default, rtol=1e-10, atol=0) and (eps > 0).sum() >= 20
    alone = [ferrari_canny(Contacts(contacts.points[k:k + 1], contacts.normals[k:k + 1], contacts.state[k:k + 1],
                                    contacts.approach[k:k + 1]), float(mu[k]))[0] for k in range(30)]
    assert np.array_equal(eps, alone)


def test_scores_do_not_change_when_the_object_and_the_grasp_turn_together():
    vertices, faces = wedge(math.radians(25))
    poses = np.concatenate([top_down(0.0), top_down(0.005, 0.004)])
    rng = np.random.default_rng(3)
    turn = pose_from_axes(rng.normal(size=(1, 3)) * 0.05, rng.normal(size=(1, 3)), rng.normal(size=(1, 3)))[0]
    moved = vertices @ turn[:3, :3].T + turn[:3, 3]
    a = pad_contacts(vertices, faces, poses, **PAD)
    b = pad_contacts(moved, faces, compose_poses(turn, poses), **PAD)
    assert np.allclose(required_friction(a), required_friction(b), atol=1e-9)
    assert np.allclose(ferrari_canny(a, 0.6), ferrari_canny(b, 0.6), atol=1e-9)


def test_the_robust_score_is_seeded_and_between_its_bounds():
    box = box_mesh((0.04, 0.06, 0.06))
    poses = np.concatenate([top_down(0.01), top_down(0.2)])
    first = robust_scores(box.vertices, box.faces, poses, np.random.default_rng(0), samples=5, **PAD)
    again = robust_scores(box.vertices, box.faces, poses, np.random.default_rng(0), samples=5, **PAD)
    assert all(np.array_equal(x, y) for x, y in zip(first, again, strict=True))
    eps, closure = first
    assert eps[0] > 0 and closure[0] > 0.5 and eps[1] == 0 and closure[1] == 0


def dexnet_force_closure(c1, c2, n1, n2, mu) -> bool:
    """dex-net's PointGraspMetrics3D.force_closure for two contacts, transcribed from its published definition:
    unoriented normals (absolute projection), each normal within arctan(mu) of the line to the other contact."""
    line = (c2 - c1) / np.linalg.norm(c2 - c1)
    alpha = math.atan(mu)
    angle1 = math.acos(min(abs(float(np.dot(n1, line))), 1.0))
    angle2 = math.acos(min(abs(float(np.dot(n2, -line))), 1.0))
    return angle1 <= alpha and angle2 <= alpha


def test_on_a_real_object_the_smallest_level_is_dexnets_sweep_on_the_same_contacts():
    from onepiece_dist.core.mesh import sample_surface
    from onepiece_dist.core.sampling import object_rng, sample_candidates
    from onepiece_dist.objects import load_object
    from onepiece_dist.objects.sources import resolve_source
    from onepiece_dist.specs.job import GripperSpec, JobSpec, SamplerSpec

    mesh = load_object(resolve_source("pybullet:named[3:4]")[0], JobSpec()).mesh
    rng = object_rng(mesh.content_id, 0)
    points, normals = sample_surface(mesh, 3000, rng)
    poses = sample_candidates(mesh, points, normals, 200, GripperSpec(), SamplerSpec(), rng).poses
    contacts = pad_contacts(mesh.vertices, mesh.faces, poses, **PAD)
    ours = smallest_level(required_friction(contacts))
    reference = []
    for k in range(len(poses)):
        held = [mu for mu in sorted(GRASPNET_LEVELS) if contacts.state[k] == 0 and dexnet_force_closure(
            *contacts.points[k], *contacts.normals[k], mu)]
        reference.append(held[0] if held else np.inf)
    agree = ours == np.array(reference)
    assert (contacts.state == 0).mean() > 0.8 and np.isfinite(ours).any() and np.isinf(ours).any()
    assert agree.mean() >= 0.99, np.flatnonzero(~agree)  # a level within rounding of an angle may differ
