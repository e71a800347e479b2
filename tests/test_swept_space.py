"""The hand's swept space as the camera saw it (core.cloud.swept_space, issue 55): free in front of the observed
surface, zero on it, unknown behind it or where nothing was seen; the grid turns with the gripper; the same bits
whatever order the cloud's points come in."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.swept_space import (
    TRUNCATION,
    DepthRays,
    hand_grid,
    space_size,
    swept_space,
    turned_half,
)
from onepiece_dist.core.frames import pose_from_axes

EYE = np.array([0.0, 0.0, 1.0])


def wall(count: int = 60_000, seed: int = 0) -> np.ndarray:
    """A table-like wall z = 0 seen from 1 m above, about 1.5 mm between points."""
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(-0.2, 0.2, (count, 2)), np.zeros(count)]


def test_free_in_front_of_the_surface_zero_on_it_unknown_behind_it_or_where_nothing_was_seen():
    rays = DepthRays.of(wall(), EYE)
    values = rays.read(np.array([[0.01, 0.0, 0.5], [0.01, 0.0, 0.0], [0.01, 0.0, -0.5],
                                 [0.01, 0.0, TRUNCATION / 2], [0.0, 0.0, 1.5], [1.0, 0.0, 0.0]]))
    assert values[0] == 1.0  # the camera saw through it
    assert abs(values[1]) < 0.05  # on the surface
    assert values[2] == -1.0  # behind the wall: occluded
    assert abs(values[3] - 0.5) < 0.05  # half the truncation in front of it
    assert values[4] == -1.0  # behind the camera
    assert values[5] == -1.0  # no point was seen along that ray


def test_a_grasp_from_above_sees_free_space_at_the_palm_and_the_table_below_the_fingertips():
    grid = hand_grid(0.02, 0.04, 0.05, 0.01)
    assert grid.shape == (space_size(), 3) and np.allclose(grid.mean(axis=0), [0.01, 0, 0])
    # the fingertips 1 cm into the table, approaching straight down
    above = pose_from_axes(np.array([[0.0, 0.0, 0.03]]), np.array([[0, 0, -1.0]]), np.array([[1.0, 0, 0]]))
    space = swept_space(DepthRays.of(wall(), EYE), above, grid)[0]
    depth_into_table = grid[:, 0] - 0.03  # how far below the table top each cell lies
    assert np.all(space[depth_into_table < -TRUNCATION] == 1.0)
    assert np.all(space[depth_into_table > 0.005] < 0)


def test_the_grid_turned_half_a_turn_is_the_turned_grasps_space():
    rng = np.random.default_rng(1)
    cloud = np.concatenate([wall(), rng.uniform(-0.03, 0.03, (5000, 3)) + [0, 0, 0.04]])
    rays = DepthRays.of(cloud, EYE + [0.3, 0.1, 0])
    grid = hand_grid(0.02, 0.04, 0.05, 0.01)
    poses = pose_from_axes(rng.uniform(-0.02, 0.02, (8, 3)) + [0, 0, 0.08],
                           rng.normal(size=(8, 3)) * 0.3 + [0, 0, -1.0], rng.normal(size=(8, 3)))
    turned = poses.copy()
    turned[:, :3, 1:3] *= -1  # (u, v, t) -> (u, -v, -t)
    assert np.array_equal(turned_half(swept_space(rays, poses, grid)), swept_space(rays, turned, grid))


def test_the_networks_said_to_read_the_space_exist_and_read_it():
    from onepiece_dist.core.cloud.swept_space import SPACE_MODELS
    from onepiece_dist.learn.models import MODELS

    assert SPACE_MODELS and all(MODELS[name]().space == space_size() for name in SPACE_MODELS)


def test_the_values_do_not_depend_on_the_clouds_point_order():
    cloud = wall(20_000, seed=2)
    grid = hand_grid(0.02, 0.04, 0.05, 0.01)
    pose = pose_from_axes(np.array([[0.01, 0.0, 0.02]]), np.array([[0.3, 0, -1.0]]), np.array([[0, 1.0, 0]]))
    shuffled = cloud[np.random.default_rng(3).permutation(len(cloud))]
    assert np.array_equal(swept_space(DepthRays.of(cloud, EYE), pose, grid),
                          swept_space(DepthRays.of(shuffled, EYE), pose, grid))
