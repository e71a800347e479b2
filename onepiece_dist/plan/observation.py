"""What the camera gives: a point cloud (PLY, PCD or NPY, metres) or a depth image with intrinsics, checked before
anything is planned on it. Bad input is refused with the file, what is wrong and the fix."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.support_check import support_plane
from onepiece_dist.core.frames import transform_points
from onepiece_dist.core.raycast import import_open3d
from onepiece_dist.errors import CloudRejected
from onepiece_dist.specs.plan import PlanSpec

MIN_POINTS = 50  # fewer observed points hold no grasp worth planning
MAX_DIAGONAL = 5.0  # m: a larger cloud is in other units (millimetres give 1000x)
MIN_DIAGONAL = 0.005  # m
CLOUD_SUFFIXES = (".ply", ".pcd", ".npy")


@dataclass(frozen=True)
class Observation:
    """points (m, 3) float64 in the frame grasps are returned in (metres); viewpoint (3,) the camera's position in
    that frame (normals face it), or None when unknown; source names where it came from; up (3,) the frame's up
    where it is known (a robot's base frame: +z), else None."""

    points: np.ndarray
    viewpoint: np.ndarray | None
    source: str
    up: np.ndarray | None = None


def check_cloud(points: np.ndarray, source: str) -> np.ndarray:
    """(m, 3) float64 ``points`` if they can be planned on; else :class:`CloudRejected` naming ``source``."""
    points = np.asarray(points)
    if points.ndim != 2 or points.shape[1] != 3:
        raise CloudRejected(f"{source}: expected (N, 3) points, got an array of shape {points.shape}")
    if len(points) == 0:
        raise CloudRejected(f"{source}: the cloud is empty: nothing was observed (is the object in view?)")
    points = points.astype(np.float64)
    bad = ~np.all(np.isfinite(points), axis=1)
    if bad.any():
        raise CloudRejected(f"{source}: {int(bad.sum())} of {len(points)} points are NaN or infinite: drop them "
                            "before planning (a depth image's missing pixels are dropped when it is read as a depth "
                            "image)")
    if len(points) < MIN_POINTS:
        raise CloudRejected(f"{source}: only {len(points)} points; at least {MIN_POINTS} are needed to plan on")
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    if diagonal > MAX_DIAGONAL:
        raise CloudRejected(f"{source}: the cloud spans {diagonal:.1f} (diagonal): wrong units? Points must be in "
                            f"metres (millimetres: scale by 0.001, giving {diagonal / 1000:.3f} m)")
    if diagonal < MIN_DIAGONAL:
        raise CloudRejected(f"{source}: the cloud spans only {diagonal:.2g} m: wrong units? Points must be in metres")
    return points


def read_cloud(path: str | Path, viewpoint: np.ndarray | None = None) -> Observation:
    """A cloud file as an :class:`Observation`. PLY and PCD through open3d; NPY as an (N, 3) float array (nothing
    unpickled). ``viewpoint`` (3,): the camera's position in the cloud's frame (a camera-frame cloud: the origin)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in CLOUD_SUFFIXES:
        raise CloudRejected(f"{path}: unknown cloud format {suffix!r}: give one of {', '.join(CLOUD_SUFFIXES)}")
    if not path.is_file():
        raise CloudRejected(f"{path}: no such file")
    if suffix == ".npy":
        try:
            points = np.load(path, allow_pickle=False)
        except ValueError as err:
            raise CloudRejected(f"{path}: not a plain numeric .npy array ({err})") from None
    else:
        o3d = import_open3d()

        points = np.asarray(o3d.io.read_point_cloud(str(path), remove_nan_points=False,
                                                    remove_infinite_points=False).points)
    view = None if viewpoint is None else np.asarray(viewpoint, dtype=np.float64)
    return Observation(check_cloud(points, str(path)), view, str(path))


def depth_to_cloud(depth: np.ndarray, fx: float, fy: float, cx: float, cy: float, source: str = "depth image",
                   camera_pose: np.ndarray | None = None) -> Observation:
    """A depth image (H, W) in metres (0, NaN or inf: no return) with pinhole intrinsics, back-projected in the
    OpenCV camera frame (x right, y down, z forward), or in the frame of ``camera_pose`` (4, 4) camera-to-frame.
    The viewpoint is the camera's position."""
    depth = np.asarray(depth, dtype=np.float64)
    if depth.ndim != 2:
        raise CloudRejected(f"{source}: a depth image is (H, W), got shape {depth.shape}")
    if min(fx, fy) <= 0:
        raise CloudRejected(f"{source}: focal lengths fx={fx}, fy={fy} must be positive (pixels)")
    rows, cols = np.nonzero(np.isfinite(depth) & (depth > 0))
    z = depth[rows, cols]
    points = np.stack([(cols - cx) * z / fx, (rows - cy) * z / fy, z], axis=1)
    viewpoint, up = np.zeros(3), None
    if camera_pose is not None:  # the robot's base frame: z is up
        pose = np.asarray(camera_pose, dtype=np.float64)
        points, viewpoint, up = transform_points(points, pose), pose[:3, 3].copy(), np.array([0.0, 0.0, 1.0])
    return Observation(check_cloud(points, source), viewpoint, source, up)


ESTIMATED_DISTANCE = 0.6  # m above the support plane's points where a camera of unknown position is put


def with_viewpoint(observation: Observation, spec: PlanSpec) -> tuple[Observation, tuple[str, ...]]:
    """``observation`` with a camera position: its own, or where none was given, one estimated on the side the
    surface was seen from (ESTIMATED_DISTANCE along the support plane's normal, which faces the objects on it),
    said in the notes; refused where it cannot be estimated (no support plane)."""
    if observation.viewpoint is not None:
        return observation, ()
    plane = None
    if spec.support_plane == "auto":
        plane = support_plane(observation.points, np.random.default_rng([spec.seed, 56]), up=observation.up)
    if plane is None:
        raise CloudRejected(f"{observation.source}: no camera position and no support plane to estimate it from: "
                            "give the camera's position in the cloud's frame (--viewpoint x,y,z; a camera-frame "
                            "cloud: 0,0,0) so that normals face the camera")
    eye = observation.points[plane.inliers].mean(axis=0) + ESTIMATED_DISTANCE * plane.normal
    note = (f"no viewpoint given: the camera was estimated at ({eye[0]:+.3f}, {eye[1]:+.3f}, {eye[2]:+.3f}), "
            f"{ESTIMATED_DISTANCE} m above the support plane on the side the objects stand; give --viewpoint for "
            "normals that face the real camera")
    return Observation(observation.points, eye, observation.source, observation.up), (note,)
