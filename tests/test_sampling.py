import numpy as np
import pytest

from onepiece_dist.core.frames import to_gripper_frame
from onepiece_dist.core.mesh import box_mesh, cylinder_mesh, sample_surface
from onepiece_dist.core.sampling import collides, object_rng, sample_candidates
from onepiece_dist.specs.job import GripperSpec, SamplerSpec

GRIPPER = GripperSpec()


def candidates(mesh, method="antipodal", count=40, seed=0):
    rng = object_rng(mesh.content_id, seed)
    points, normals = sample_surface(mesh, 4000, rng)
    return points, sample_candidates(mesh, points, normals, count, GRIPPER, SamplerSpec(method=method), rng)


def test_antipodal_box_grasps_close_across_parallel_faces():
    mesh = box_mesh((0.03, 0.05, 0.12))
    points, cands = candidates(mesh)
    assert len(cands.poses) == 40
    assert np.all(cands.widths <= GRIPPER.max_opening)
    closing = cands.poses[:, :3, 1]
    # on a box the antipodal axis is a face normal: x (3 cm) or y (5 cm); z (12 cm) is wider than the hand
    assert np.all(np.max(np.abs(closing), axis=1) > 0.999)
    assert np.allclose(np.sort(np.unique(np.round(cands.widths, 4))), [0.03, 0.05][:len(np.unique(
        np.round(cands.widths, 4)))], atol=1e-4)
    assert not collides(points, cands.poses, GRIPPER).any()


def test_candidate_centre_lies_in_the_closing_region():
    mesh = cylinder_mesh(0.02, 0.1)
    _, cands = candidates(mesh)
    assert len(cands.poses) > 0  # np.all over no candidates would pass
    centre = to_gripper_frame(np.zeros((1, 3)), cands.poses)[:, 0]  # the cylinder axis point at the origin
    assert np.all(centre[:, 0] > 0) and np.all(np.abs(centre[:, 1]) < GRIPPER.max_opening / 2)


def test_sampler_is_deterministic_per_object_and_seed():
    mesh = box_mesh((0.03, 0.05, 0.06))
    _, a = candidates(mesh, seed=3)
    _, b = candidates(mesh, seed=3)
    _, c = candidates(mesh, seed=4)
    assert np.array_equal(a.poses, b.poses) and not np.array_equal(a.poses, c.poses)


def test_object_wider_than_the_hand_gets_no_candidates():
    _, cands = candidates(box_mesh((0.1, 0.1, 0.1)))
    assert len(cands.poses) == 0


@pytest.mark.parametrize("method", ["antipodal", "normal"])
def test_both_samplers_give_right_handed_collision_free_frames(method):
    mesh = cylinder_mesh(0.025, 0.06)
    points, cands = candidates(mesh, method=method)
    assert len(cands.poses) > 0
    rot = cands.poses[:, :3, :3]
    assert np.allclose(np.linalg.det(rot), 1.0) and np.allclose(rot.transpose(0, 2, 1) @ rot, np.eye(3), atol=1e-9)
    assert not collides(points, cands.poses, GRIPPER).any()


def test_the_batched_collision_check_equals_the_per_pose_one():
    from onepiece_dist.core.frames import in_box, pose_from_axes
    from onepiece_dist.core.sampling import gripper_boxes

    rng = np.random.default_rng(5)
    points = rng.uniform(-0.06, 0.06, (3000, 3))
    poses = pose_from_axes(rng.uniform(-0.1, 0.1, (2500, 3)), rng.normal(size=(2500, 3)), rng.normal(size=(2500, 3)))
    expected = np.array([any(in_box(to_gripper_frame(points, pose[None])[0], lo, hi).any()
                             for lo, hi in gripper_boxes(GRIPPER)) for pose in poses])
    assert 0 < expected.sum() < len(poses)
    assert np.array_equal(collides(points, poses, GRIPPER), expected)


@pytest.mark.parametrize("preset", ["box", "panda"])
def test_poses_above_the_table_tried_on_the_points_above_it_alone_get_every_points_answer(preset):
    from onepiece_dist.core.cloud.grasps import PLANE_CLEARANCE, Blockers, SupportPlane, above_plane
    from onepiece_dist.core.frames import pose_from_axes
    from onepiece_dist.gripper.presets import PRESETS

    gripper = GRIPPER if preset == "box" else GripperSpec(**PRESETS[preset])
    rng = np.random.default_rng(3)
    table = np.column_stack([rng.uniform(-0.15, 0.15, (6000, 2)), rng.uniform(-0.004, 0.004, 6000)])
    box = rng.uniform([-0.015, -0.025, 0.0], [0.015, 0.025, 0.08], (1500, 3))
    points = rng.permutation(np.vstack([table, box]))
    plane = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.0, np.abs(points[:, 2]) < 0.004)
    # a top-down hand whose fingertips stop 0.5 mm above the clearance, over a table point 2.6 mm up
    tip = np.array([0.1, 0.1, PLANE_CLEARANCE + 0.0005])
    above_the_point = pose_from_axes((tip + [0, 0, gripper.finger_length])[None], np.array([[0.0, 0, -1]]),
                                     np.array([[0.0, 1, 0]]))
    finger = tip + [0, gripper.max_opening / 2 + gripper.finger_thickness / 2, 0.0001]
    poses = np.concatenate([above_the_point, pose_from_axes(rng.uniform([-0.08, -0.08, 0.0], [0.08, 0.08, 0.15],
                                                                        (600, 3)),
                                                            rng.normal(size=(600, 3)), rng.normal(size=(600, 3)))])
    points = np.vstack([points, finger])
    every_point = collides(points, poses, gripper)
    above = above_plane(poses, gripper, plane)
    blockers = Blockers.of(points, plane)

    hit_points, hit = blockers.blocked(poses, gripper)
    assert len(blockers.high) < len(points) / 2  # the table's points, but for those above the clearance, left out
    assert above[0] and every_point[0] and hit_points[0]  # a point above the clearance still blocks
    assert 0 < np.sum(every_point & above) < np.sum(above) < len(poses)
    assert np.array_equal(hit_points, every_point & above) and np.array_equal(hit, every_point | ~above)


def test_the_planes_inliers_are_counted_as_the_per_plane_products_count_them():
    from onepiece_dist.core.cloud.grasps import dot3, near_plane_counts

    rng = np.random.default_rng(8)
    points = np.vstack([rng.uniform(-0.2, 0.2, (4000, 3)), np.round(rng.uniform(-0.2, 0.2, (4000, 3)), 3)])
    anchors, normals = points[rng.integers(0, len(points), 50)], rng.normal(size=(50, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    normals[:10] = [0.0, 0.0, 1.0]  # on the rounded points' millimetre steps, the boundary cases
    expected = [int(np.sum(np.abs(dot3(points - p, n)) < 0.004)) for n, p in zip(normals, anchors, strict=True)]
    assert len(set(expected)) > 10
    assert near_plane_counts(points, normals, anchors, 0.004) == expected
