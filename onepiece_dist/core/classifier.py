"""The paper's projection-plane classifier.

For each code, the occupancy (a, b, c) over (u, v, t) is projected onto the (u, v), (u, t) and (v, t) planes
(a cell is set when any voxel along the dropped axis is set). On each projection, edge features are the 2 x 2
windows that match one of the four L-shaped kernels, i.e. windows with exactly three of four cells set. With S_p
the projected area (set cells) and N_p the feature count, plane p scores S_p / (S_uv + S_ut + S_vt) * N_p; the
highest score wins. Ties: the larger area wins, then the order uv, ut, vt.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.voxel import unpack_codes

PLANES = ("uv", "ut", "vt")
_DROPPED_AXIS = {"uv": 3, "ut": 2, "vt": 1}  # axes of the (n, a, b, c) occupancy


@dataclass(frozen=True)
class PlaneClasses:
    """areas (n, 3) int64, features (n, 3) int64, scores (n, 3) float64 in PLANES order; plane (n,) int8."""

    areas: np.ndarray
    features: np.ndarray
    scores: np.ndarray
    plane: np.ndarray


def projections(occupancy: np.ndarray) -> list[np.ndarray]:
    """The three (n, ., .) bool projections of (n, a, b, c) occupancy, in PLANES order."""
    return [occupancy.any(axis=_DROPPED_AXIS[p]) for p in PLANES]


def l_feature_count(projection: np.ndarray) -> np.ndarray:
    """Number of 2 x 2 windows with exactly three set cells. (n, h, w) bool -> (n,) int64."""
    p = projection.astype(np.int8)
    if p.shape[1] < 2 or p.shape[2] < 2:
        return np.zeros(len(p), dtype=np.int64)
    window = p[:, :-1, :-1] + p[:, 1:, :-1] + p[:, :-1, 1:] + p[:, 1:, 1:]
    return (window == 3).sum(axis=(1, 2)).astype(np.int64)


def classify_occupancy(occupancy: np.ndarray) -> PlaneClasses:
    """Classify (n, a, b, c) bool occupancies."""
    projs = projections(occupancy)
    areas = np.stack([p.sum(axis=(1, 2)) for p in projs], axis=1).astype(np.int64)
    features = np.stack([l_feature_count(p) for p in projs], axis=1)
    total = np.maximum(areas.sum(axis=1, keepdims=True), 1)
    scores = areas / total * features
    order = np.lexsort((-np.arange(3)[None, :].repeat(len(scores), 0).T, areas.T, scores.T), axis=0)
    plane = order[-1].astype(np.int8) if len(scores) else np.zeros(0, np.int8)
    return PlaneClasses(areas, features, scores, plane)


def classify_codes(codes: np.ndarray, grid_shape: tuple[int, int, int]) -> PlaneClasses:
    """Classify (n, B) uint8 packed codes."""
    return classify_occupancy(unpack_codes(codes, grid_shape))
