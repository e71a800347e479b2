"""The object points of one view told apart: points whose cells of GAP touch (26-connected) are one object, so
objects further apart than about GAP are separate. A planner that completes the shape of "the object" from the
whole cloud (core.cloud.completion) would otherwise join two objects standing side by side into one hull and
fill the space between them; a grasp is checked on the object it closes on (picks.shape_check)."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.frames import gripper_frame_batches
from onepiece_dist.core.grasp_context import object_centre

GAP = 0.01  # m: about two rays apart at the pick camera's 0.8 m, yet less than a finger's width
MIN_SHARE = 0.1  # an object holds at least this share of the view's object points (less: stray points)
MIN_POINTS = 30  # and at least this many
BLOCK = 1 << 19  # points x poses compared at once (closed_on_each): about 4 MB an array

_HALF_NEIGHBOURS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                             if (i, j, k) > (0, 0, 0)], dtype=np.int64)  # 13: each touching pair once


def point_groups(points: np.ndarray, gap: float = GAP) -> np.ndarray:
    """(n,) int: the connected group of each of ``points`` (n, 3), 0 the largest, then by size (ties: the group
    met first in cell order)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    cells, inverse = np.unique(np.floor(np.asarray(points) / gap).astype(np.int64), axis=0, return_inverse=True)
    low, span = cells.min(axis=0) - 1, cells.max(axis=0) - cells.min(axis=0) + 3
    keys = _keys(cells, low, span)  # sorted, as np.unique sorts the cells lexicographically
    rows, cols = [], []
    for offset in _HALF_NEIGHBOURS:
        wanted = _keys(cells + offset, low, span)
        at = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
        hit = keys[at] == wanted
        rows.append(np.nonzero(hit)[0])
        cols.append(at[hit])
    row, col = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(row), dtype=np.int8), (row, col)), shape=(len(cells), len(cells)))
    _, cell_group = connected_components(graph, directed=False)
    group = cell_group[inverse.ravel()]
    order = np.argsort(-np.bincount(group), kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[group]


def _keys(cells: np.ndarray, low: np.ndarray, span: np.ndarray) -> np.ndarray:
    shifted = cells - low
    return (shifted[:, 0] * span[1] + shifted[:, 1]) * span[2] + shifted[:, 2]


def separate_objects(points: np.ndarray, gap: float = GAP) -> list[np.ndarray]:
    """The objects among ``points`` (the view's cloud less its support plane): each group of at least MIN_SHARE
    of them and MIN_POINTS, largest first; the stray groups belong to none. One object (or none): ``[points]``
    whole, stray points and all."""
    groups = point_groups(points, gap)
    sizes = np.bincount(groups) if len(groups) else np.zeros(0, dtype=np.int64)
    kept = np.nonzero((sizes >= MIN_POINTS) & (sizes >= MIN_SHARE * len(points)))[0]
    if len(kept) < 2:
        return [points]
    return [points[groups == g] for g in kept]


def closed_on(objects: list[np.ndarray], pose: np.ndarray, depth: float, width: float, height: float) -> int:
    """Which of ``objects`` the grasp ``pose`` (gripper to cloud, docs/gripper_frame.md) closes on: the one with
    the most points in its closing region (depth x width x height), else the one nearest the region's centre."""
    return int(_closed_on(objects, np.asarray(pose, dtype=np.float64).reshape(1, 4, 4), depth, width, height)[0])


def closed_on_each(objects: list[np.ndarray], poses: np.ndarray, depth: float, width: float, height: float
                   ) -> np.ndarray:
    """(n,) int: the one of ``objects`` each of ``poses`` closes on (closed_on); 0 for all where there is one."""
    if len(objects) < 2:
        return np.zeros(len(poses), dtype=np.int64)
    return _closed_on(objects, np.asarray(poses, dtype=np.float64).reshape(-1, 4, 4), depth, width, height)


def _closed_on(objects: list[np.ndarray], poses: np.ndarray, depth: float, width: float, height: float
               ) -> np.ndarray:
    """closed_on of each of ``poses`` (n, 4, 4): each object's points in the gripper frames of a block of poses at
    once (core.frames.gripper_frame_batches: the same bits on every CPU, as the crops cut them); the nearest point
    only where no object has one inside."""
    clouds = [np.asarray(points, dtype=np.float64) for points in objects]
    inside = np.zeros((len(clouds), len(poses)), dtype=np.int64)
    for k, points in enumerate(clouds):
        for start, (u, v, t) in gripper_frame_batches(points, poses, pairs=BLOCK):
            within = (u >= 0) & (u < depth) & (np.abs(v) < width / 2) & (np.abs(t) < height / 2)
            inside[k, start:start + len(u)] = np.count_nonzero(within, axis=1)
    chosen = inside.argmax(axis=0)
    empty = np.flatnonzero(inside.max(axis=0) == 0)
    if len(empty):
        centres = poses[empty, :3, 3] + poses[empty, :3, 0] * depth / 2
        chosen[empty] = np.array([[float(np.min(np.sum((points - centre) ** 2, axis=1))) for centre in centres]
                                  for points in clouds]).argmin(axis=0)
    return chosen.astype(np.int64)


def grasped_centres(objects: list[np.ndarray], poses: np.ndarray, depth: float, width: float, height: float
                    ) -> np.ndarray:
    """The observed object's centre (core.grasp_context.object_centre) of the one of ``objects``
    (separate_objects), (3,); of several, each of ``poses``' own object's centre (closed_on), (n, 3)."""
    if len(objects) == 1:
        return object_centre(objects[0])
    centres = np.array([object_centre(o) for o in objects])
    return centres[closed_on_each(objects, poses, depth, width, height)].reshape(-1, 3)
