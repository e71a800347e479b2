"""What lies around the fingers, as the camera saw it (issue 55): the hand's swept volume sampled on a fixed grid
in the gripper frame, each cell read against the view's depth. A crop holds only the observed points inside the
closing region; it cannot say whether the space beside the fingers was seen to be free, or lies behind what the
camera saw (occluded: unknown), where a finger may meet the part of the object nobody saw.

Each cell's value is the observed depth along the cell's ray minus the cell's own depth, truncated at TRUNCATION
and scaled to [-1, 1]: +1 free (the camera saw through it), 0 on the observed surface, -1 behind it or where the
camera saw nothing (unknown). The depth image is rebuilt from the cloud and the camera's position (a z-buffer of
the cloud's points over rays of RAY_CELL), so the planner computes the same values from any camera's cloud as the
labels were made with. Fixed-order products only: the same bits on every CPU.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SPACE_CELLS = (6, 10, 3)  # along u (approach), v (closing), t: 1 x 1 x 0.7 cm cells for the default gripper
TRUNCATION = 0.02  # m: depths further than this from the observed surface read as fully free or unknown
RAY_CELL = 0.005  # the rays' spacing (tangent of the angle): 3-4 mm at 0.6-0.8 m, twice a 320 px view's pixel
_OFFSET = 1 << 20  # ray indices are shifted by this to pack (x, y) into one non-negative key
SPACE_MODELS = frozenset({"pointnet_context_space"})  # the networks that read it (learn.models)


def space_size() -> int:
    return int(np.prod(SPACE_CELLS))


def hand_grid(palm_depth: float, closing_depth: float, half_width: float, half_height: float) -> np.ndarray:
    """(G, 3) cell centres in the gripper frame (u then v then t order): u from ``palm_depth`` behind the closing
    region to the fingertips (``closing_depth``), v over +-``half_width`` (both fingers at the widest opening), t
    over +-``half_height`` (the fingers' height)."""
    u_low, u_high, v_half, t_half = -palm_depth, closing_depth, half_width, half_height
    axes = [low + (np.arange(n) + 0.5) * (high - low) / n
            for (low, high), n in zip(((u_low, u_high), (-v_half, v_half), (-t_half, t_half)), SPACE_CELLS,
                                      strict=True)]
    u, v, t = np.meshgrid(*axes, indexing="ij")
    return np.stack([u.ravel(), v.ravel(), t.ravel()], axis=1)


@dataclass(frozen=True)
class DepthRays:
    """The cloud's nearest depth along each ray from ``eye``: ``basis`` (3, 3) rows right, up, forward (towards the
    middle of the cloud's bounding box); ``keys`` (k,) sorted ray keys, ``depth`` (k,) their nearest depth."""

    eye: np.ndarray
    basis: np.ndarray
    keys: np.ndarray
    depth: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, eye: np.ndarray) -> DepthRays:
        points, eye = np.asarray(points, dtype=np.float64), np.asarray(eye, dtype=np.float64)
        basis = _basis((points.min(axis=0) + points.max(axis=0)) / 2 - eye)
        keys, depth = _project(points, eye, basis)
        order = np.lexsort((depth, keys))
        keys, depth = keys[order], depth[order]
        first = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]) if len(keys) else np.zeros(0, np.int64)
        return cls(eye, basis, keys[first], depth[first])

    def read(self, points: np.ndarray) -> np.ndarray:
        """(m,) float32 the value of each of ``points`` (m, 3): see the module's docstring."""
        keys, depth = _project(points, self.eye, self.basis, keep_behind=True)
        at = np.minimum(np.searchsorted(self.keys, keys), max(len(self.keys) - 1, 0))
        value = np.full(len(keys), -1.0)
        if len(self.keys):
            seen = (self.keys[at] == keys) & (depth > 0)
            value[seen] = np.clip((self.depth[at[seen]] - depth[seen]) / TRUNCATION, -1.0, 1.0)
        return value.astype(np.float32)


def swept_space(rays: DepthRays, poses: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """(n, G) float32 the value of each ``grid`` cell (G, 3, gripper frame) at each of ``poses`` (n, 4, 4)."""
    poses = np.asarray(poses, dtype=np.float64)
    if len(poses) == 0:
        return np.zeros((0, len(grid)), np.float32)
    rot, origin = poses[:, :3, :3], poses[:, :3, 3]
    cells = np.empty((len(poses), len(grid), 3))
    for axis in range(3):  # ((r0 u + r1 v) + r2 t) + origin, each product rounded on its own
        cells[:, :, axis] = (rot[:, axis, 0, None] * grid[None, :, 0] + rot[:, axis, 1, None] * grid[None, :, 1]
                             + rot[:, axis, 2, None] * grid[None, :, 2]) + origin[:, axis, None]
    return rays.read(cells.reshape(-1, 3)).reshape(len(poses), len(grid))


def turned_half(space: np.ndarray) -> np.ndarray:
    """``space`` (n, G) of the same grasps turned half a turn about the approach axis ((u, v, t) -> (u, -v, -t)):
    the grid is symmetric, so its cells are the same cells in reversed v and t order."""
    a, b, c = SPACE_CELLS
    return np.ascontiguousarray(space.reshape(-1, a, b, c)[:, :, ::-1, ::-1].reshape(len(space), -1))


def _basis(forward: np.ndarray) -> np.ndarray:
    forward = forward / max(float(np.sqrt(forward[0] ** 2 + forward[1] ** 2 + forward[2] ** 2)), 1e-12)
    helper = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(forward, helper)
    right /= np.sqrt(right[0] ** 2 + right[1] ** 2 + right[2] ** 2)
    return np.stack([right, np.cross(right, forward), forward])


def _project(points: np.ndarray, eye: np.ndarray, basis: np.ndarray, keep_behind: bool = False
             ) -> tuple[np.ndarray, np.ndarray]:
    """(keys, depth) of ``points`` seen from ``eye``; points behind the eye dropped, or with ``keep_behind`` kept
    with depth 0 (they read as unknown)."""
    d = np.asarray(points, dtype=np.float64) - eye
    x, y, z = ((d[:, 0] * row[0] + d[:, 1] * row[1]) + d[:, 2] * row[2] for row in basis)
    ahead = z > 1e-6
    if not keep_behind:
        x, y, z = x[ahead], y[ahead], z[ahead]
        ahead = np.ones(len(z), bool)
    safe = np.where(ahead, z, 1.0)
    ix = np.clip(np.floor(x / safe / RAY_CELL), -_OFFSET + 1, _OFFSET - 1).astype(np.int64) + _OFFSET
    iy = np.clip(np.floor(y / safe / RAY_CELL), -_OFFSET + 1, _OFFSET - 1).astype(np.int64) + _OFFSET
    return ix * (2 * _OFFSET) + iy, np.where(ahead, z, 0.0)
