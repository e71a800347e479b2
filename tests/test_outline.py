"""The object's outline seen from each grasp (issue 55, core.cloud.outline): a farthest-point sample of the observed
object's points in each gripper frame, and the label store's column that keeps it."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.outline import farthest_points, outline
from onepiece_dist.core.frames import matrix_from_quat


def _pose(rot: np.ndarray, position) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rot, position
    return pose


def test_the_farthest_point_sample_spreads_over_the_object_and_reaches_its_ends():
    rng = np.random.default_rng(0)
    rod = np.concatenate([rng.uniform([0, 0, 0], [0.01, 0.01, 0.01], (500, 3)),  # a dense lump at one end
                          [[0.3, 0.0, 0.0]]])  # and one point 30 cm away
    chosen = farthest_points(rod, 8)
    assert chosen[0] == 0 and 500 in chosen  # the far end is sampled although it is one point of 501
    assert len(set(chosen)) == 8
    assert np.array_equal(farthest_points(rod[:3], 8), [0, 1, 2, 0, 1, 2, 0, 1])  # few points: cycled
    assert len(farthest_points(np.zeros((0, 3)), 8)) == 0


def test_the_outline_is_the_sample_in_each_gripper_frame_about_the_closing_centre():
    rng = np.random.default_rng(1)
    points = rng.uniform(-0.05, 0.05, (300, 3)) + [0.4, 0.1, 0.05]
    quaternion = np.array([0.3, -0.2, 0.5, 0.78])
    turned = matrix_from_quat(quaternion / np.linalg.norm(quaternion))
    poses = np.stack([_pose(np.eye(3), [0.4, 0.1, 0.0]), _pose(turned, [0.35, 0.12, 0.08])])
    depth = 0.04
    seen = outline(points, poses, depth, count=16)
    sample = points[farthest_points(points, 16)]
    for k, pose in enumerate(poses):
        centre = pose[:3, 3] + pose[:3, 0] * depth / 2
        assert np.allclose(seen[k], (sample - centre) @ pose[:3, :3], atol=1e-7)
    # distances between the outline's points do not depend on the grasp that sees them
    gaps = [np.linalg.norm(s[:, None] - s[None], axis=2) for s in seen.astype(np.float64)]
    assert np.allclose(gaps[0], gaps[1], atol=1e-6)
    assert seen.dtype == np.float32 and outline(np.zeros((0, 3)), poses, depth, 16).shape == (2, 16, 3)


def test_a_label_store_made_before_the_outline_reads_with_none_per_row(tmp_path):
    import shutil

    from onepiece_dist.store.pick_labels import LabelledObject, read_pick_labels, write_pick_labels

    rows, rng = 3, np.random.default_rng(2)
    made = LabelledObject(0, "box", "ok", points=np.zeros((rows, 8, 3), np.float16),
                          context=np.zeros((rows, 6), np.float32), space=np.zeros((rows, 0), np.float16),
                          outline=rng.normal(size=(rows, 64, 3)).astype(np.float16), success=np.ones(rows, bool),
                          held=np.ones(rows, np.int8), failure=np.zeros(rows, np.int8),
                          view=np.zeros(rows, np.int16), pose=np.tile(np.eye(4), (rows, 1, 1)))
    path = tmp_path / "pick_labels.zarr"
    write_pick_labels(path, [made], {}, 1.0, 1.0)
    assert np.array_equal(read_pick_labels(path).outline, made.outline)
    shutil.rmtree(path / "outline")  # as the stores made before labels kept it
    older = read_pick_labels(path)
    assert older.outline.shape == (rows, 0, 3) and len(older.subset(np.arange(2)).outline) == 2
