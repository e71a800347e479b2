"""Depth views rendered in pybullet, back-projected to the object frame, and partial-view crops in a job."""

import numpy as np
import open3d as o3d
import pytest

from onepiece_dist.api import Client
from onepiece_dist.core.frames import invert_poses
from onepiece_dist.core.mesh import box_mesh
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.runtime.local import run_local
from onepiece_dist.sim.views import camera_for_grasps, object_views, orbit_cameras
from onepiece_dist.store import open_dataset

HALF = np.array([0.03, 0.02, 0.05])
FACE_NORMALS = np.vstack([np.eye(3), -np.eye(3)])


def box_faces(points: np.ndarray) -> np.ndarray:
    """(n,) index into FACE_NORMALS of the box face nearest each point."""
    gap = np.concatenate([HALF - points, HALF + points], axis=1)  # distance to +x, +y, +z, -x, -y, -z planes
    return np.argmin(np.abs(gap), axis=1)


def distance_to_box(points: np.ndarray) -> np.ndarray:
    q = np.abs(points) - HALF
    return np.abs(np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0))


@pytest.mark.sim
def test_depth_views_of_a_box_back_project_onto_its_visible_faces():
    box = box_mesh(tuple(2 * HALF))
    views = object_views(box.vertices, box.faces, count=10, size=128, fov_deg=45)
    assert len(views.cameras) == 10
    for k, camera in enumerate(views.cameras):
        points = views.cloud(k).astype(np.float64)
        assert len(points) > 1000
        assert distance_to_box(points).max() < 0.001  # on the surface within a millimetre
        eye = camera[:3, 3]
        facing = (eye - points) @ FACE_NORMALS.T  # > 0 where a face looks towards the camera
        seen = box_faces(points)
        assert np.all(facing[np.arange(len(points)), seen] > 0), "a point on a face turned away from the camera"
        for face in range(6):  # every face squarely in view got points
            if (eye @ FACE_NORMALS[face]) - np.abs(FACE_NORMALS[face]) @ HALF > 0.5 * np.linalg.norm(eye):
                assert np.any(seen == face)


def test_orbit_cameras_look_at_the_object_and_grasps_get_the_camera_behind_them():
    box = box_mesh((0.04, 0.04, 0.04))
    cameras = np.array([c.pose for c in orbit_cameras(box.vertices, 32, 64, 45)])
    assert np.allclose(np.einsum("kij,kj->ki", invert_poses(cameras), np.c_[np.zeros((32, 3)), np.ones(32)])[:, :2],
                       0, atol=1e-9)  # the centre lies on every optical axis
    approach = np.eye(4)[None].repeat(2, 0)
    approach[1, :3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # second grasp approaches along -z
    chosen = camera_for_grasps(cameras, approach)
    viewing = -cameras[chosen, :3, 2]
    assert viewing[0] @ [1, 0, 0] > 0.9 and viewing[1] @ [0, 0, -1] > 0.9


def near_view(points_object: np.ndarray, view_points: np.ndarray, tolerance: float = 0.001) -> np.ndarray:
    tree = o3d.geometry.KDTreeFlann(o3d.geometry.PointCloud(o3d.utility.Vector3dVector(view_points)))
    return np.array([tree.search_knn_vector_3d(p, 1)[2][0] <= tolerance**2 for p in points_object])


def grasp_points_in_chosen_view(dataset) -> list[float]:
    """Per grasp: share of its stored points within 1 mm of the view of the camera chosen for it."""
    cameras, owner = dataset["views/camera"], dataset["views/camera_object"]
    view_points, point_camera = dataset["views/points"], dataset["views/point_camera"]
    poses, objects, points = dataset["grasps/pose"], dataset["grasps/object"], dataset["grasps/points"]
    shares = []
    for i in range(0, len(poses), 7):
        mine = np.flatnonzero(owner == objects[i])
        camera = mine[camera_for_grasps(cameras[mine], poses[i:i + 1])[0]]
        in_object = points[i].astype(np.float64) @ poses[i, :3, :3].T + poses[i, :3, 3]
        shares.append(float(near_view(in_object, view_points[point_camera == camera].astype(np.float64)).mean()))
    return shares


@pytest.mark.ray
@pytest.mark.slow
def test_a_job_with_partial_view_crops_runs_end_to_end_on_embedded_ray(ray_session, spec_factory, tmp_path):
    views = {"count": 12, "image_size": 192}
    spec = spec_factory(objects="primitives[0:4]", grasps_per_object=24, views={**views, "crop": "partial"},
                        stages=["ingest", "extract", "dedup", "assemble", "label", "train"],
                        sim={"perturbations_per_patch": 1}, train={"epochs": 2}, output=str(tmp_path / "partial.zarr"),
                        keep_all_points=True)
    final = Client().submit(spec).wait(timeout=300)
    assert final.state == "succeeded", final.error
    partial = open_dataset(spec.output)
    assert partial["views/camera"].shape == (4 * 12, 4, 4) and partial.has("assembled/grasps/points")
    assert final.training.epochs >= 1 and partial.has("train/train_loss")
    assert min(grasp_points_in_chosen_view(partial)) > 0.99  # the crop is what the chosen camera saw
    full_spec = spec.model_copy(update={"views": spec.views.model_copy(update={"crop": "full"}),
                                        "stages": ("ingest", "extract", "dedup"),
                                        "output": str(tmp_path / "full.zarr")})
    run_local(full_spec)
    # the full surface includes what the camera cannot see: some crops reach behind the object
    assert min(grasp_points_in_chosen_view(open_dataset(full_spec.output))) < 0.9


def test_views_are_stored_in_the_object_frame_of_each_object(spec_factory, tmp_path):
    spec = spec_factory(objects="primitives[0:2]", sim={"physics": False}, views={"count": 4, "image_size": 64})
    run_local(spec)
    data = open_dataset(spec.output)
    refs = resolve_source(spec.objects)
    assert len(refs) == 2  # a loop over no object would pass
    for k, ref in enumerate(refs):
        mesh = load_object(ref, spec).mesh
        mine = np.isin(data["views/point_camera"], np.flatnonzero(data["views/camera_object"] == k))
        cloud = data["views/points"][mine]
        assert len(cloud) > 100  # an empty cloud would pass the bounds below
        assert np.all(cloud >= mesh.vertices.min(axis=0) - 1e-3) and np.all(cloud <= mesh.vertices.max(axis=0) + 1e-3)


def test_flying_pixels_mix_only_an_edges_pixels_between_its_two_depths_and_none_draws_nothing():
    from onepiece_dist.sim.views import EDGE_JUMP, Camera, buffer_of, linear_depth, mixed_edges

    metres = np.full((40, 40), 0.7)
    metres[10:30, 12:28] = 0.5  # a box 20 cm before the table
    metres[:, :3] = 0.0  # and pixels that saw nothing
    camera = Camera(np.eye(4), 40, 45.0, 0.05, 2.0)
    assert np.allclose(linear_depth(buffer_of(metres, camera), camera), metres, rtol=0, atol=1e-9)
    rng = np.random.default_rng(0)
    assert np.array_equal(mixed_edges(metres, 0.0, rng), metres)
    assert rng.random() == np.random.default_rng(0).random()  # nothing drawn
    mixed = mixed_edges(metres, 1.0, np.random.default_rng(1))
    changed = mixed != metres
    box = np.zeros_like(changed)
    box[10:30, 12:28] = True
    rim = np.zeros_like(box)
    for axis, step in ((0, 1), (0, -1), (1, 1), (1, -1)):
        rim |= box != np.roll(box, step, axis)  # a pixel whose 4-neighbour lies on the other side of the box's edge
    assert changed.sum() >= 0.95 * rim.sum() and not np.any(changed & ~rim)
    assert np.all((mixed[changed] > 0.5) & (mixed[changed] < 0.7)) and EDGE_JUMP < 0.2
    assert np.all(mixed[:, :3] == 0.0) and np.all(mixed[:, 3] == 0.7)  # nothing mixed with what was not seen
