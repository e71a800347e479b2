"""A depth camera's own files of objects on a table, made in simulation (`onepiece scene`): what a robot's camera
would write, to try `onepiece grasp` end to end without a camera, or to check a camera set-up against. The objects
are settled on the pick benchmark's table (one, or several side by side or piled as `onepiece pick --clutter`
settles them), seen by one seeded camera as the benchmark draws it, and written as:

- ``depth.png``: 16-bit millimetres along the camera's axis, 0 where it saw nothing;
- ``intrinsics.json``: the pinhole ``K`` (pixels) that puts each pixel where the renderer saw it;
- ``camera_pose.json``: the camera-to-base ``matrix`` (OpenCV axes: x right, y down, z forward); the base frame is
  the table's, z up with the table top at z = 0;
- ``scene.json``: the objects and their resting poses (mesh frame to base), the camera, and the command that plans
  on the files.

Read back by `onepiece grasp` (plan.camera_files) the depth gives the benchmark's cloud of the view to within the
millimetre the PNG keeps."""

from __future__ import annotations

import json
import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core import portable
from onepiece_dist.core.cloud.flying import FLYING_TOLERANCE
from onepiece_dist.core.raycast import import_open3d
from onepiece_dist.errors import SourceError
from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.clutter import WORKSPACE, loaded_object, scene_triangles, settle_scene
from onepiece_dist.sim.pick import TABLE_BOX, PickWorld, pick_camera
from onepiece_dist.sim.views import depth_images, linear_depth, mixed_edges
from onepiece_dist.specs.job import GripperSpec, JobSpec
from onepiece_dist.specs.plan import CameraSpec

SCENE_STREAM = 77  # the stream of a scene's drops and camera, apart from every benchmark's
OPENCV = np.diag([1.0, -1.0, -1.0, 1.0])  # OpenGL camera axes (x right, y up, looking along -z) to OpenCV's


@dataclass(frozen=True)
class SceneFiles:
    """The files written for one scene, and what stands on its table."""

    folder: Path
    objects: tuple[str, ...]
    centre: tuple[float, float, float]
    drop_flying: float = 0.0  # m: where the camera's flying pixels are in the image, the planner drops them

    def grasp_command(self) -> str:
        """The `onepiece grasp` command that plans on these files, in the base frame, within the scene's box (and
        dropping the image's flying pixels where it has them: docs/picks.md)."""
        depth, intrinsics, pose = (shlex.quote(str(self.folder / name))
                                   for name in ("depth.png", "intrinsics.json", "camera_pose.json"))
        drop = f" --drop-flying {self.drop_flying:g}" if self.drop_flying > 0 else ""
        return (f"onepiece grasp {depth} --intrinsics {intrinsics} --camera-pose {pose} --workspace "
                f"{self.workspace()}{drop}")

    def workspace(self) -> str:
        """The box around the scene's objects (base frame, m: x0,y0,z0,x1,y1,z1) that `onepiece grasp` plans in."""
        x, y, _ = self.centre
        return ",".join(f"{v:.2f}" for v in (x - WORKSPACE, y - WORKSPACE, -0.02, x + WORKSPACE, y + WORKSPACE, 0.4))


def write_scene(objects: str, folder: str | Path, count: int = 1, seed: int = 0, camera: CameraSpec | None = None,
                job: JobSpec | None = None, pile: bool = False) -> SceneFiles:
    """The first ``count`` objects of the source ``objects`` settled on the table (seeded by ``seed``; side by
    side, or in a ``pile``: picks.clutter.settle_scene), seen by one camera drawn as ``camera`` says (default: the
    pick benchmark's), written to ``folder`` (module doc). Objects load as ``job`` asks (units, scale, physics;
    default JobSpec's); a bad one raises MeshRejected, too few SourceError."""
    camera, job = camera or CameraSpec(), job or JobSpec()

    refs = resolve_source(objects)[:count]
    if len(refs) < count:
        raise SourceError(f"objects {objects!r}: {len(refs)} object(s) found, {count} asked for (--count)")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    scene = tuple(loaded_object(ref, job, folder / "collision") for ref in refs)
    world = PickWorld(GripperSpec())  # the gripper waits above the table
    try:
        rng = np.random.default_rng([seed, SCENE_STREAM])
        resting = settle_scene(world, scene, rng, pile)
    finally:
        world.close()
    vertices, faces = scene_triangles(scene, resting)
    centre = np.mean([v.mean(axis=0) for v in vertices], axis=0)
    seen = _camera(centre, rng, camera)
    _write_depth(folder / "depth.png", _depth(np.vstack(vertices), faces, seen, camera, rng))
    _write_json(folder / "intrinsics.json", {"K": intrinsics(seen).tolist()})
    _write_json(folder / "camera_pose.json", {"matrix": (seen.pose @ OPENCV).tolist()})
    written = SceneFiles(folder, tuple(o.name for o in scene), tuple(float(v) for v in centre),
                         FLYING_TOLERANCE if camera.flying_pixels > 0 else 0.0)
    _write_json(folder / "scene.json", {
        "objects": [{"name": o.name, "resting_pose": pose.tolist()} for o, pose in zip(scene, resting, strict=True)],
        "seed": seed, "pile": pile, "camera": camera.model_dump(mode="json"), "grasp": written.grasp_command()})
    return written


def intrinsics(camera) -> np.ndarray:
    """(3, 3) pinhole K (pixels) of a square ``camera`` (sim.views.Camera) as sim.views.back_project places its
    pixels: pixel (row, col) at x = (2 col / size - 1) t d and, OpenCV's y down, y = (2 (row + 1) / size - 1) t d,
    t the tangent of half the field of view."""
    size = camera.size
    focal = size / (2.0 * float(portable.tan(np.radians(camera.fov_deg) / 2)))
    return np.array([[focal, 0.0, size / 2], [0.0, focal, size / 2 - 1.0], [0.0, 0.0, 1.0]])


def _camera(centre: np.ndarray, rng: np.random.Generator, camera: CameraSpec):
    return pick_camera(centre, rng, camera.distance, camera.elevation_deg, camera.image_size, camera.fov_deg).camera


def _depth(vertices: np.ndarray, faces: np.ndarray, camera, spec: CameraSpec, rng: np.random.Generator
           ) -> np.ndarray:
    """(size, size) uint16 millimetres of the objects (``vertices``, ``faces``: world frame) and the table, 0 where
    the camera saw nothing; with ``spec``'s share of flying pixels at its edges (sim.views.mixed_edges) and its
    Gaussian noise (m) on every pixel that saw something, each drawn from ``rng`` where asked for."""
    metres = linear_depth(depth_images(vertices, faces, [camera], TABLE_BOX)[0], camera)
    if spec.flying_pixels > 0:
        metres = mixed_edges(metres, spec.flying_pixels, rng)
    if spec.depth_noise > 0:
        seen = metres > 0
        metres[seen] = np.maximum(metres[seen] + rng.normal(0.0, spec.depth_noise, int(seen.sum())), 0.001)
    return np.clip(np.round(metres * 1000.0), 0, np.iinfo(np.uint16).max).astype(np.uint16)


def _write_depth(path: Path, millimetres: np.ndarray) -> None:
    o3d = import_open3d()
    if not o3d.io.write_image(str(path), o3d.geometry.Image(np.ascontiguousarray(millimetres))):
        raise OSError(f"{path}: the depth PNG could not be written")


def _write_json(path: Path, data: dict) -> None:
    path.write_text(json.dumps(data, indent=1) + "\n")
