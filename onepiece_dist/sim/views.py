"""Depth views of an object rendered headless by pybullet (TinyRenderer), back-projected to partial point clouds
in the object frame: what a depth camera sees, for partial-view crops (docs/views.md).

Camera convention: a camera pose is camera-to-object (4, 4) with OpenGL axes: x right, y up, the camera looks
along -z. Depth buffers are pybullet's non-linear [0, 1] values; :func:`back_project` inverts them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core import portable
from onepiece_dist.core.frames import transform_points

NEAR_FRACTION = 0.05  # near plane as a fraction of the camera distance
FAR_FACTOR = 3.0  # far plane as a multiple of the camera distance
EDGE_JUMP = 0.02  # m: a depth step between neighbouring pixels this large is an edge, where flying pixels stand


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: pose (4, 4) camera-to-object, square image ``size`` px, vertical ``fov_deg``,
    clip planes ``near`` < ``far`` (m)."""

    pose: np.ndarray
    size: int
    fov_deg: float
    near: float
    far: float


def sphere_directions(count: int) -> np.ndarray:
    """(count, 3) float64 unit vectors spread evenly on the sphere (Fibonacci lattice), deterministic."""
    k = np.arange(count) + 0.5
    z = 1 - 2 * k / count
    azimuth = np.pi * (1 + 5**0.5) * k
    r = np.sqrt(1 - z**2)
    sin, cos = portable.sin_cos(azimuth)
    return np.stack([r * cos, r * sin, z], axis=1)


def _length(vector: np.ndarray) -> float:
    """|vector| of a (3,) vector in one fixed order (np.linalg.norm of a vector is a BLAS dot product)."""
    return float(np.sqrt((vector[0] * vector[0] + vector[1] * vector[1]) + vector[2] * vector[2]))


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(4, 4) camera-to-object pose of a camera at ``eye`` looking at ``target`` (OpenGL axes)."""
    back = (eye - target) / _length(eye - target)
    helper = np.array([0.0, 0.0, 1.0]) if abs(back[2]) < 0.95 else np.array([0.0, 1.0, 0.0])
    right = np.cross(helper, back)
    right /= _length(right)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, np.cross(back, right), back, eye
    return pose


def orbit_cameras(vertices: np.ndarray, count: int, size: int, fov_deg: float, margin: float = 1.2,
                  distance: float | None = None) -> list[Camera]:
    """``count`` cameras on a sphere around the mesh's bounding-box centre, ``distance`` away or (None) far enough
    that the whole object fits the field of view with ``margin``. vertices (V, 3) float."""
    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    centre, radius = (lower + upper) / 2, _length(upper - lower) / 2
    distance = distance or framing_distance(radius, fov_deg, margin)
    return [camera_at(centre + distance * d, centre, size, fov_deg) for d in sphere_directions(count)]


def framing_distance(radius: float, fov_deg: float, margin: float = 1.2) -> float:
    """Camera distance at which a sphere of ``radius`` fills the field of view, with ``margin``."""
    return margin * radius / float(portable.sin(np.radians(fov_deg) / 2))


def camera_at(eye: np.ndarray, target: np.ndarray, size: int, fov_deg: float) -> Camera:
    """A camera at ``eye`` looking at ``target``, clip planes scaled to their distance."""
    distance = _length(np.asarray(eye, dtype=np.float64) - target)
    return Camera(look_at(np.asarray(eye, float), np.asarray(target, float)), size, fov_deg,
                  NEAR_FRACTION * distance, FAR_FACTOR * distance)


def render_depth(vertices: np.ndarray, faces: np.ndarray, cameras: list[Camera]) -> np.ndarray:
    """(len(cameras), size, size) float32 pybullet depth buffers of the mesh (1.0 = background).

    vertices (V, 3) float, faces (F, 3) int; all cameras share one image size.
    """
    return np.stack(depth_images(vertices, faces, cameras)).astype(np.float32)


def depth_images(vertices: np.ndarray, faces: np.ndarray, cameras: list[Camera],
                 box: tuple[np.ndarray, np.ndarray] | None = None) -> list[np.ndarray]:
    """Each camera's (size, size) float64 depth buffer of a scene of the mesh (its vertices where they are) and,
    where given, a ``box`` (half extents (3,), centre (3,)): the one scene builder of every depth view (the
    job's views, the pick benchmark's camera over its table)."""
    import pybullet as pb

    client = pb.connect(pb.DIRECT)
    try:
        shape = pb.createVisualShape(pb.GEOM_MESH, vertices=np.asarray(vertices, float).tolist(),
                                     indices=np.asarray(faces, int).ravel().tolist(), physicsClientId=client)
        pb.createMultiBody(baseVisualShapeIndex=shape, physicsClientId=client)
        if box is not None:
            block = pb.createVisualShape(pb.GEOM_BOX, halfExtents=list(box[0]), physicsClientId=client)
            pb.createMultiBody(baseVisualShapeIndex=block, basePosition=list(box[1]), physicsClientId=client)
        return [depth_image(pb, client, camera) for camera in cameras]
    finally:
        pb.disconnect(client)


def depth_image(pb, client: int, camera: Camera) -> np.ndarray:
    eye, target = camera.pose[:3, 3], camera.pose[:3, 3] - camera.pose[:3, 2]
    view = pb.computeViewMatrix(eye.tolist(), target.tolist(), camera.pose[:3, 1].tolist())
    proj = pb.computeProjectionMatrixFOV(camera.fov_deg, 1.0, camera.near, camera.far)
    _, _, _, depth, _ = pb.getCameraImage(camera.size, camera.size, view, proj, renderer=pb.ER_TINY_RENDERER,
                                          flags=pb.ER_NO_SEGMENTATION_MASK, physicsClientId=client)
    return np.reshape(depth, (camera.size, camera.size))


def back_project(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(M, 3) float64 object-frame points of the pixels that hit the object. depth (size, size) buffer."""
    size = camera.size
    rows, cols = np.nonzero(depth < 1.0 - 1e-6)
    distance = _buffer_distance(depth[rows, cols], camera)
    half = float(portable.tan(np.radians(camera.fov_deg) / 2))
    # TinyRenderer samples pixel (row, col) at the lower-left corner of the pixel with rows flipped:
    # x = col, y = size - 1 - row in window coordinates (measured: exact to 1e-6 m on a box).
    x = (2.0 * cols / size - 1.0) * half * distance
    y = (1.0 - 2.0 * (rows + 1.0) / size) * half * distance
    local = np.stack([x, y, -distance], axis=1)
    return transform_points(local, camera.pose)  # fixed-order products: the same points on every CPU


def linear_depth(buffer: np.ndarray, camera: Camera) -> np.ndarray:
    """(size, size) float64 depth (m) along the camera's axis of each pixel of a depth ``buffer``, 0 where it saw
    nothing: what a depth camera writes (pixel (row, col) as :func:`back_project` places it)."""
    hit = buffer < 1.0 - 1e-6
    return np.where(hit, _buffer_distance(np.where(hit, buffer, 0.0), camera), 0.0)


def buffer_of(metres: np.ndarray, camera: Camera) -> np.ndarray:
    """The depth buffer (pybullet's [0, 1] values; 1 where nothing was seen) of depth ``metres`` along the camera's
    axis (0 where nothing was seen): linear_depth inverted."""
    near, far = camera.near, camera.far
    seen = metres > 0
    z_ndc = (far + near - 2.0 * near * far / np.where(seen, metres, 1.0)) / (far - near)
    return np.where(seen, (z_ndc + 1.0) / 2.0, 1.0)


FLYING_TOLERANCE = 0.005  # m off both neighbouring surfaces' continuations: a pixel that fits neither is flying


def flying_mask(metres: np.ndarray, tolerance: float = FLYING_TOLERANCE) -> np.ndarray:
    """(size, size) bool: the pixels of depth ``metres`` (0 where nothing was seen) whose depth fits neither
    neighbouring surface's linear continuation (2 d[i-1] - d[i-2] and 2 d[i+1] - d[i+2]) within ``tolerance``,
    along rows or along columns: a flying pixel stands between a near surface and a far one, where a face seen
    grazing steps evenly. Pixels within 2 of an unseen one are never flagged."""
    padded = np.pad(metres, 2)
    size_r, size_c = metres.shape
    out = np.zeros(metres.shape, dtype=bool)
    for axis in (0, 1):
        def shifted(k: int, axis: int = axis) -> np.ndarray:
            return padded[2 + k:2 + k + size_r, 2:-2] if axis == 0 else padded[2:-2, 2 + k:2 + k + size_c]
        seen = (metres > 0) & (shifted(-1) > 0) & (shifted(-2) > 0) & (shifted(1) > 0) & (shifted(2) > 0)
        low, high = 2.0 * shifted(-1) - shifted(-2), 2.0 * shifted(1) - shifted(2)
        out |= seen & (np.abs(metres - low) > tolerance) & (np.abs(metres - high) > tolerance)
    return out


def mixed_edges(metres: np.ndarray, share: float, rng: np.random.Generator, jump: float = EDGE_JUMP) -> np.ndarray:
    """Depth ``metres`` (size, size; 0 where nothing was seen) with a depth camera's flying pixels: each pixel with
    a 4-neighbour more than ``jump`` (m) nearer or further (both seen), at a ``share`` of them drawn from ``rng``,
    takes a depth drawn uniformly between its own and that neighbour's (the one whose depth differs most): a pixel
    that straddles an object's edge mixes the object with what lies behind it. Nothing is drawn where ``share`` is 0."""
    if share <= 0:
        return metres
    padded = np.pad(metres, 1)
    around = np.stack([padded[:-2, 1:-1], padded[2:, 1:-1], padded[1:-1, :-2], padded[1:-1, 2:]])
    gap = np.where((around > 0) & (metres > 0), around - metres, 0.0)
    widest = np.take_along_axis(gap, np.argmax(np.abs(gap), axis=0)[None], axis=0)[0]
    edge = np.flatnonzero(np.abs(widest) > jump)
    mixed = edge[rng.random(len(edge)) < share]
    out = metres.copy()
    out.flat[mixed] += rng.random(len(mixed)) * widest.flat[mixed]
    return out


def _buffer_distance(values: np.ndarray, camera: Camera) -> np.ndarray:
    """Depth along the camera's axis (m) of pybullet depth-buffer ``values`` in [0, 1)."""
    near, far = camera.near, camera.far
    z_ndc = 2.0 * values.astype(np.float64) - 1.0
    return 2.0 * near * far / (far + near - z_ndc * (far - near))


@dataclass(frozen=True)
class ObjectViews:
    """Partial point clouds of one object. cameras (K, 4, 4) float32 camera-to-object poses; points (M, 3)
    float32 object-frame points; point_view (M,) int32 camera row of each point."""

    cameras: np.ndarray
    points: np.ndarray
    point_view: np.ndarray

    def cloud(self, view: int) -> np.ndarray:
        """(m, 3) points seen by camera ``view``."""
        return self.points[self.point_view == view]


def object_views(vertices: np.ndarray, faces: np.ndarray, count: int, size: int, fov_deg: float,
                 distance: float | None = None) -> ObjectViews:
    """Render ``count`` orbit views of a mesh (``distance`` away, or framing it) and back-project them.
    vertices (V, 3), faces (F, 3)."""
    cameras = orbit_cameras(vertices, count, size, fov_deg, distance=distance)
    return views_from(vertices, faces, cameras)


def views_from(vertices: np.ndarray, faces: np.ndarray, cameras: list[Camera]) -> ObjectViews:
    """Render the mesh from ``cameras`` and back-project each depth image."""
    depths = render_depth(vertices, faces, cameras)
    clouds = [back_project(depth, camera) for depth, camera in zip(depths, cameras, strict=True)]
    return ObjectViews(np.array([c.pose for c in cameras], dtype=np.float32).reshape(-1, 4, 4),
                       np.concatenate(clouds).astype(np.float32) if clouds else np.zeros((0, 3), np.float32),
                       np.repeat(np.arange(len(clouds), dtype=np.int32), [len(c) for c in clouds]))


def camera_for_grasps(cameras: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(N,) int: for each gripper pose (N, 4, 4), the camera (K, 4, 4) whose viewing direction is closest to the
    grasp's approach axis, i.e. the camera a robot approaching that way would look through."""
    viewing = -cameras[:, :3, 2]  # cameras look along their -z
    approach = poses[:, :3, 0]
    a, v = approach[:, None, :], viewing[None, :, :]
    return np.argmax((a[..., 0] * v[..., 0] + a[..., 1] * v[..., 1]) + a[..., 2] * v[..., 2], axis=1)
