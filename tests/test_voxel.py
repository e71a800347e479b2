import numpy as np
import pytest

from onepiece_dist.core.frames import pose_from_axes, to_gripper_frame
from onepiece_dist.core.voxel import canonical_codes, crop_codes, pack_codes, unpack_codes, voxel_indices

GRID = (4, 8, 2)
RES = 0.01


def test_pack_unpack_round_trip_and_bit_order():
    occ = np.zeros((1, *GRID), dtype=bool)
    occ[0, 0, 0, 1] = True  # flat index 1 -> byte 0, bit 6 (MSB first)
    occ[0, 3, 7, 1] = True  # flat index 63 -> byte 7, bit 0
    codes = pack_codes(occ)
    assert codes.shape == (1, 8)
    assert codes[0, 0] == 0b0100_0000 and codes[0, 7] == 0b0000_0001
    assert np.array_equal(unpack_codes(codes, GRID), occ)


def test_voxel_indices_follow_the_closing_region_convention():
    pts = np.array([[0.0, -0.04, -0.01], [0.0399, 0.0399, 0.0099], [-0.001, 0, 0], [0.01, 0.04, 0]])
    flat = voxel_indices(pts, GRID, RES)
    assert flat[0] == 0 and flat[1] == 63
    assert flat[2] == -1 and flat[3] == -1  # behind the palm; on the open edge |v| = width/2


def test_crop_codes_of_a_plane_between_the_fingers():
    # a square patch of points in the plane v = 0 in front of an identity-pose gripper
    grid = np.stack(np.meshgrid(np.linspace(0.001, 0.039, 20), [0.001], np.linspace(-0.009, 0.009, 10)),
                    -1).reshape(-1, 3)
    codes, counts = crop_codes(grid, np.eye(4)[None], GRID, RES)
    occ = unpack_codes(codes, GRID)[0]
    assert counts[0] == len(grid)
    assert occ[:, 4, :].all() and occ.sum() == 8  # every u, both t, only the voxel column just above v = 0


def test_crop_codes_moves_points_into_each_gripper_frame():
    rng = np.random.default_rng(1)
    pts = rng.uniform(-0.05, 0.05, (500, 3))
    poses = pose_from_axes(rng.normal(size=(5, 3)) * 0.01, rng.normal(size=(5, 3)), rng.normal(size=(5, 3)))
    codes, _ = crop_codes(pts, poses, GRID, RES)
    for k in range(5):
        flat = voxel_indices(to_gripper_frame(pts, poses[k:k + 1])[0], GRID, RES)
        occ = np.zeros(64, bool)
        occ[flat[flat >= 0]] = True
        assert np.array_equal(unpack_codes(codes[k:k + 1], GRID)[0].ravel(), occ)


@pytest.mark.parametrize("seed", range(5))
def test_canonical_form_is_shared_by_a_code_and_its_turned_twin(seed):
    rng = np.random.default_rng(seed)
    occ = rng.random((50, *GRID)) < 0.3
    codes = pack_codes(occ)
    turned = pack_codes(occ[:, :, ::-1, ::-1])
    assert np.array_equal(canonical_codes(codes, GRID), canonical_codes(turned, GRID))
    canon = canonical_codes(codes, GRID)
    assert all(c.tobytes() in (a.tobytes(), b.tobytes()) for c, a, b in zip(canon, codes, turned, strict=True))


def random_poses(rng: np.random.Generator, count: int, spread: float) -> np.ndarray:
    return pose_from_axes(rng.uniform(-spread, spread, (count, 3)), rng.normal(size=(count, 3)),
                          rng.normal(size=(count, 3)))


def test_the_batched_crop_equals_the_per_pose_crop_through_the_index(monkeypatch):
    from onepiece_dist.core import voxel

    rng = np.random.default_rng(3)
    points = rng.uniform(-0.05, 0.05, (6000, 3))
    poses = random_poses(rng, 700, 0.04)  # several batches of the dense path
    monkeypatch.setattr(voxel, "DENSE_POINTS", 10**9)
    dense = voxel.crop_regions(points, poses, (4, 8, 2), 0.01, keep_points=True)
    monkeypatch.setattr(voxel, "DENSE_POINTS", 0)
    indexed = voxel.crop_regions(points, poses, (4, 8, 2), 0.01, keep_points=True)
    assert np.array_equal(dense[0], indexed[0]) and np.array_equal(dense[1], indexed[1])
    assert dense[1].sum() > 0 and all(np.array_equal(a, b) for a, b in zip(dense[2], indexed[2], strict=True))
    for pose, inside in zip(poses[:50], dense[2], strict=False):  # what crop_points gives, in its order
        assert np.array_equal(inside, voxel.crop_points(points, pose, (4, 8, 2), 0.01))


def test_a_grid_index_given_by_the_caller_crops_as_the_one_built_for_it():
    """The assembly sorts the one object's points once for both of its checks, in cells of another size."""
    from onepiece_dist.core import voxel
    from onepiece_dist.core.spatial import PointGrid

    rng = np.random.default_rng(4)
    points = rng.uniform(-0.05, 0.05, (6000, 3))
    poses = random_poses(rng, 200, 0.04)
    own = voxel.crop_regions(points, poses, (4, 8, 2), 0.01, keep_points=True)
    for cell in (0.007, 0.035):
        given = voxel.crop_regions(points, poses, (4, 8, 2), 0.01, keep_points=True, index=PointGrid(points, cell))
        assert np.array_equal(own[0], given[0]) and np.array_equal(own[1], given[1]) and own[1].sum() > 0
        assert all(np.array_equal(a, b) for a, b in zip(own[2], given[2], strict=True))


def test_rotate_points_is_the_matrix_product_summed_in_one_fixed_order():
    from onepiece_dist.core.frames import rotate_points

    rng = np.random.default_rng(3)
    points, rot = rng.normal(size=(1000, 3)), np.linalg.qr(rng.normal(size=(3, 3)))[0]
    turned = rotate_points(points, rot)
    assert turned.dtype == np.float64 and np.allclose(turned, points @ rot, rtol=0, atol=1e-15)
    by_hand = (points[:, 0:1] * rot[0] + points[:, 1:2] * rot[1]) + points[:, 2:3] * rot[2]
    assert np.array_equal(turned, by_hand)  # bit for bit: no BLAS, no fused multiply-add
    assert np.array_equal(rotate_points(points[::-1], rot), turned[::-1])  # a row's result is its own
