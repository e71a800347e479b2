"""What a depth camera and a robot give, read into an :class:`Observation` in the robot's base frame (issue 56):
a 16-bit PNG depth image in camera units (or an NPY), its intrinsics (fx,fy,cx,cy, or a JSON file with those keys
or a 3x3 ``K``, or a ROS CameraInfo's 9 values of ``K``/``k``; refused where made for another image), the camera's
pose in the robot's base frame (a JSON file: ``{"matrix": 4x4}`` or ``{"position":
[x, y, z], "quaternion": [x, y, z, w]}``, camera to base, the OpenCV camera frame: x right, y down, z forward), and
a workspace box the cloud is cropped to. Bad input is refused naming the file and the fix."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.flying import without_flying
from onepiece_dist.core.frames import matrix_from_quat, transform_points
from onepiece_dist.core.raycast import import_open3d
from onepiece_dist.errors import CloudRejected
from onepiece_dist.plan.observation import Observation, check_cloud, depth_to_cloud

PNG_DEPTH_SCALE = 0.001  # a 16-bit PNG holds millimetres unless told otherwise
LOOKING_UP = 0.9  # more of a view's points above its camera than this: the camera pose is refused (check_looks_down)


@dataclass(frozen=True)
class Intrinsics:
    """A pinhole camera's focal lengths and principal point (pixels); the image ``width`` and ``height`` they are
    for where their file says (a ROS CameraInfo's or a RealSense's), and where they were read from."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int | None = None
    height: int | None = None
    source: str = "--intrinsics"

    def check(self, shape: tuple[int, ...], image: str) -> None:
        """Refuse a depth image of ``shape`` (H, W) from ``image`` that these intrinsics were not made for: another
        size than their file says, or a principal point outside it (those of another stream or resolution)."""
        height, width = shape[:2]
        if self.width is not None and self.height is not None and (self.width, self.height) != (width, height):
            across, down = width / self.width, height / self.height
            scale = f"{across:g}" if across == down else f"{across:g} (fx, cx) and {down:g} (fy, cy)"
            raise CloudRejected(
                f"{self.source}: these intrinsics are for a {self.width}x{self.height} image, {image} is "
                f"{width}x{height}: give the intrinsics of the stream the depth image came from (or, for the same "
                f"lens at another resolution, fx, fy, cx, cy scaled by {scale})")
        if not (0 <= self.cx <= width and 0 <= self.cy <= height):
            raise CloudRejected(
                f"{self.source}: the principal point ({self.cx:g}, {self.cy:g}) lies outside {image}'s "
                f"{width}x{height} pixels: are these the intrinsics of another stream or resolution? Give those "
                "of the depth image (its camera info or calibration)")


def _json(path: Path, what: str):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise CloudRejected(f"{path}: not a readable {what} JSON file ({err})") from None


def read_intrinsics(text: str) -> Intrinsics:
    """``fx,fy,cx,cy`` or the path of a JSON file with those keys or a 3x3 ``K``."""
    path = Path(text)
    if path.suffix.lower() == ".json":
        data = _json(path, "intrinsics")
        size = _image_size(data, path)
        key = next((key for key in ("K", "k") if isinstance(data, dict) and key in data), None)
        if key is not None:  # 3x3, or a ROS CameraInfo's 9 in row order
            k = np.asarray(data[key], dtype=np.float64)
            if k.size != 9 or k.ndim not in (1, 2):
                raise CloudRejected(f"{path}: {key} must be 3x3 (or its 9 values in row order), got shape {k.shape}")
            k = k.reshape(3, 3)
            return Intrinsics(k[0, 0], k[1, 1], k[0, 2], k[1, 2], *size, str(path))
        if isinstance(data, dict) and all(key in data for key in ("fx", "fy", "cx", "cy")):
            return Intrinsics(*(float(data[key]) for key in ("fx", "fy", "cx", "cy")), *size, str(path))
        raise CloudRejected(f'{path}: give {{"fx", "fy", "cx", "cy"}} or a 3x3 "K" (pixels)')
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 4:
        raise CloudRejected(f"--intrinsics {text!r}: give fx,fy,cx,cy (pixels) or a JSON file")
    return Intrinsics(*values)


def _image_size(data, path: Path) -> tuple[int | None, int | None]:
    """The image ``width`` and ``height`` an intrinsics file gives (both, or neither: (None, None))."""
    if not isinstance(data, dict) or "width" not in data or "height" not in data:
        return None, None
    try:
        width, height = int(data["width"]), int(data["height"])
    except (TypeError, ValueError):
        width = height = 0
    if width <= 0 or height <= 0 or (width, height) != (data["width"], data["height"]):
        raise CloudRejected(f"{path}: width and height are the image's size in pixels, whole and positive, got "
                            f"{data['width']!r} and {data['height']!r}")
    return width, height


def read_camera_pose(path: str | Path) -> np.ndarray:
    """(4, 4) camera-to-base transform from a JSON file (a 4x4 ``matrix``, or ``position`` + ``quaternion``)."""
    path = Path(path)
    data = _json(path, "camera pose")
    if isinstance(data, dict) and "matrix" in data:
        pose = np.asarray(data["matrix"], dtype=np.float64)
        if pose.shape != (4, 4) or not np.allclose(pose[3], [0, 0, 0, 1]):
            raise CloudRejected(f"{path}: matrix must be 4x4 with a last row 0 0 0 1")
        rotation = pose[:3, :3]
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-4) or np.linalg.det(rotation) < 0:
            raise CloudRejected(f"{path}: the matrix's rotation is not a rotation (orthonormal, det +1)")
        return pose
    if isinstance(data, dict) and "position" in data and "quaternion" in data:
        position, quaternion = np.asarray(data["position"], float), np.asarray(data["quaternion"], float)
        if position.shape != (3,) or quaternion.shape != (4,) or not np.any(quaternion):
            raise CloudRejected(f"{path}: position is [x, y, z] and quaternion [x, y, z, w]")
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = matrix_from_quat(quaternion), position
        return pose
    raise CloudRejected(f'{path}: give {{"matrix": 4x4}} or {{"position": [x, y, z], "quaternion": [x, y, z, w]}} '
                        "(camera to robot base)")


def read_depth(path: str | Path, depth_scale: float | None = None) -> np.ndarray:
    """(H, W) float64 depth in metres from a 16-bit PNG (times ``depth_scale``, default 0.001) or an NPY (times
    ``depth_scale``, default 1); 0 stays 0 (no return)."""
    path = Path(path)
    if not path.is_file():
        raise CloudRejected(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".png":
        o3d = import_open3d()

        raw = np.asarray(o3d.io.read_image(str(path)))
        if raw.ndim != 2 or raw.dtype != np.uint16:
            raise CloudRejected(f"{path}: a depth PNG is one 16-bit channel, got {raw.dtype} of shape {raw.shape}")
        return raw.astype(np.float64) * (PNG_DEPTH_SCALE if depth_scale is None else depth_scale)
    if suffix == ".npy":
        try:
            raw = np.load(path, allow_pickle=False)
        except ValueError as err:
            raise CloudRejected(f"{path}: not a plain numeric .npy array ({err})") from None
        return np.asarray(raw, dtype=np.float64) * (1.0 if depth_scale is None else depth_scale)
    raise CloudRejected(f"{path}: a depth image is a 16-bit .png or an .npy, not {suffix!r}")


def read_workspace(text: str) -> tuple[np.ndarray, np.ndarray]:
    """``xmin,ymin,zmin,xmax,ymax,zmax`` (m) -> (lower, upper)."""
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        values = np.zeros(0)
    if len(values) != 6 or np.any(values[:3] >= values[3:]):
        raise CloudRejected(f"--workspace {text!r}: give xmin,ymin,zmin,xmax,ymax,zmax (m), each min below its max")
    return values[:3], values[3:]


def crop_to_workspace(observation: Observation, lower: np.ndarray, upper: np.ndarray,
                      pose: np.ndarray | None = None) -> Observation:
    """The observation's points inside the box (given in the frame ``pose`` maps the points into, when given),
    checked again (an empty box is refused)."""
    points = observation.points
    framed = points if pose is None else transform_points(points, pose)
    inside = np.all((framed >= lower) & (framed <= upper), axis=1)
    source = f"{observation.source} (workspace {lower.tolist()} to {upper.tolist()})"
    if len(points) and not inside.any():
        spans = ", ".join(f"{axis} [{low:+.2f}, {high:+.2f}]"
                          for axis, low, high in zip("xyz", framed.min(axis=0), framed.max(axis=0), strict=True))
        frame = "the robot's base frame (the camera pose's)" if pose is not None else "the cloud's frame"
        raise CloudRejected(f"{source}: none of its {len(points)} points lies in the workspace; in {frame} they "
                            f"span {spans} m: give the box in that frame, in metres")
    return Observation(check_cloud(points[inside], source), observation.viewpoint, observation.source,
                       observation.up)


def check_looks_down(observation: Observation, camera_pose: np.ndarray, pose_file: str | Path) -> None:
    """Refuse a camera pose that has the camera look up at nearly all it saw (LOOKING_UP of the points above it in
    the base frame): the planner takes the base frame's +z as up and the table below the objects, and a pose in
    another camera convention turns the cloud over."""
    pose = np.asarray(camera_pose, dtype=np.float64)
    heights = transform_points(observation.points, pose)[:, 2] - pose[2, 3]
    above = float(np.mean(heights > 0)) if len(heights) else 0.0
    if above > LOOKING_UP:
        raise CloudRejected(
            f"{pose_file}: with this camera pose {above:.0%} of {observation.source}'s points lie above the camera, "
            "which would look up at its scene: is the pose camera to base, in OpenCV's camera axes (x right, y "
            "down, z forward)? An OpenGL camera's pose (y up, z backward) is turned into it by negating its "
            "rotation's second and third columns; a base-to-camera pose by inverting it")


def depth_observation(path: str | Path, intrinsics: Intrinsics, depth_scale: float | None = None,
                      drop_flying: float = 0.0) -> Observation:
    """A depth image file back-projected in the OpenCV camera frame, its flying pixels dropped at ``drop_flying``
    (m; core.cloud.flying; 0 keeps every pixel)."""
    depth = read_depth(path, depth_scale)
    intrinsics.check(depth.shape, str(path))
    depth = without_flying(depth, drop_flying)
    return depth_to_cloud(depth, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy, source=str(path))


def with_known_up(observation: Observation, camera_pose: np.ndarray) -> Observation:
    """A camera-frame observation that knows where up is: the base frame's +z seen from the camera (planning stays
    in the camera's frame, so the grasps are those of the camera's cloud; GraspPlan.transformed moves them)."""
    up = np.asarray(camera_pose, dtype=np.float64)[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    return Observation(observation.points, observation.viewpoint, observation.source, up)


def in_frame(observation: Observation, pose: np.ndarray) -> Observation:
    """The observation moved by ``pose`` (4, 4) into another frame (for its drawing beside the moved plan)."""
    view = None if observation.viewpoint is None else transform_points(observation.viewpoint[None], pose)[0]
    up = None if observation.up is None else np.asarray(pose)[:3, :3] @ observation.up
    return Observation(transform_points(observation.points, pose), view, observation.source, up)
