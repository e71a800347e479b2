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
