"""Flying pixels taken out of a view (core.cloud.veils, PlanSpec.veils): a veil trailing off an object's edges goes,
the surfaces the camera sees stay."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from onepiece_dist.core.cloud.support_check import support_plane
from onepiece_dist.core.cloud.veils import veil_mask, without_veils


def box_views(flying: float) -> tuple[np.ndarray, np.ndarray]:
    """A 6 x 4 x 8 cm box settled on the pick table, seen by a seeded camera, every edge pixel mixed at
    ``flying`` 1: (the cloud, the camera's position)."""
    from onepiece_dist.core.mesh import box_mesh
    from onepiece_dist.sim.pick import PickWorld, observe, pick_camera
    from onepiece_dist.specs.job import GripperSpec

    mesh = box_mesh((0.06, 0.04, 0.08))
    world = PickWorld(GripperSpec())
    try:
        world.load_object([mesh.vertices], 0.06 * 0.04 * 0.08, 400.0)
        rng = np.random.default_rng(3)
        resting = world.settle(rng, mesh.vertices)
        camera = pick_camera(resting[:3, 3], rng, (0.5, 0.8), (30.0, 70.0), 320, 45.0).camera
    finally:
        world.close()
    cloud = observe(mesh.vertices, mesh.faces, resting, camera, np.random.default_rng(1), flying_pixels=flying)
    return cloud, camera.pose[:3, 3]


@pytest.mark.sim
def test_a_veil_off_a_boxs_edges_is_dropped_and_what_the_camera_sees_of_it_stays():
    exact, viewpoint = box_views(0.0)
    flying, same = box_views(1.0)
    assert np.array_equal(viewpoint, same)
    veil = cKDTree(exact).query(flying)[0] > 0.003  # points standing off every exact point
    assert veil.sum() > 30  # a view without veils would pass the bounds below
    plane = support_plane(flying, np.random.default_rng(0), towards=viewpoint - flying.mean(axis=0))
    kept, kept_plane = without_veils(flying, plane, viewpoint)
    dropped = cKDTree(kept).query(flying)[0] > 0  # each kept point is one of the cloud's, unmoved
    assert dropped[veil].mean() > 0.6  # most of the veil goes
    assert (dropped & ~veil & ~plane.inliers).sum() <= 0.01 * (~plane.inliers & ~veil).sum()  # the box stays
    assert not np.any(dropped & plane.inliers)  # the table is left as it is
    assert np.array_equal(kept_plane.inliers, plane.inliers[~dropped])  # in step with the points


def test_a_surface_facing_the_camera_holds_no_veil_and_one_along_its_rays_is_one():
    rng = np.random.default_rng(0)
    viewpoint = np.array([0.0, 0.0, 0.6])
    facing = np.column_stack([rng.uniform(-0.05, 0.05, (400, 2)), np.full(400, 0.05)])  # seen from above
    along = np.column_stack([np.full(400, 0.2), rng.uniform(-0.05, 0.05, 400), rng.uniform(0.0, 0.1, 400)])
    along[:, 0] = 0.2 * (0.6 - along[:, 2]) / 0.6  # on the plane x = z-scaled: each point on a ray's plane
    assert not veil_mask(facing, viewpoint).any()
    assert veil_mask(along, viewpoint).mean() > 0.9
    assert veil_mask(facing[:2], viewpoint).shape == (2,)
