"""Contact keys: what each finger pad meets, as a dedup key that the contacts decide.

The occupancy code (:mod:`onepiece_dist.core.voxel`) says which voxels of the closing region hold surface. It keeps
neither where the surface lies inside a voxel nor how it slopes, and those decide how a pad presses on it: at
10 mm, a face square to the closing axis and one tilted past the friction cone fill the same voxels. A contact key
keeps, for each finger and each cell of its pad, how much farther the pad travels before it meets surface in that
cell than where it first meets surface at all (the relief under the pad, quantized), and the opening at first
contact. Two grasps with one key meet the same relief under both pads, wherever the object sits between them.

Key layout, ``(n, K)`` uint8 with ``K = 2 a c + 1`` for ``a = depth / cell`` pad cells along u and
``c = height / cell`` along t: byte ``(s a + i) c + k`` is pad ``s``'s cell ``(i, k)``, which covers
``u in [i cell, (i+1) cell)`` and ``t in [-H/2 + k cell, ...)``; pad 0 is the finger at ``v = -W/2`` closing
towards +v, pad 1 the finger at ``v = +W/2`` closing towards -v. A cell's byte is
``min(floor((gap - pad's least gap) / step), levels - 1)``, or ``levels`` where no surface point of the crop lies
in the cell (the pad's finger meets nothing there). The last byte is ``min(floor(opening / width_step), 254)``
for the opening at first contact ``W - least gap of pad 0 - least gap of pad 1``, or 255 for an empty crop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.voxel import bytewise_smaller

EMPTY_CROP = 255  # the last byte of a crop with no point


@dataclass(frozen=True)
class ContactKeySpec:
    """How a contact key quantizes (metres): pad cell edge, relief step, relief levels before 'farther', opening
    step. The region is the gripper's closing region, ``(depth, width, height)`` along (u, v, t)."""

    region: tuple[float, float, float]
    cell: float = 0.01
    step: float = 0.002
    levels: int = 4
    width_step: float = 0.005

    def __post_init__(self) -> None:
        if not 1 <= self.levels <= 254:
            raise ValueError(f"levels={self.levels} must lie in 1..254")
        for name in ("cell", "step", "width_step"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}={getattr(self, name)} must be positive")
        self.pad_cells  # noqa: B018  (checks that the cell divides the region)

    @property
    def pad_cells(self) -> tuple[int, int]:
        """(a, c): pad cells along u and t."""
        depth, _, height = self.region
        cells = []
        for name, extent in (("depth", depth), ("height", height)):
            n = extent / self.cell
            if abs(n - round(n)) > 1e-6 or round(n) < 1:
                raise ValueError(f"cell={self.cell} must divide the closing region's {name}={extent} "
                                 f"into a whole number of cells (got {n:.4f})")
            cells.append(int(round(n)))
        return cells[0], cells[1]

    @property
    def key_bytes(self) -> int:
        a, c = self.pad_cells
        return 2 * a * c + 1


def pad_gaps(rows: np.ndarray, points_g: np.ndarray, count: int, spec: ContactKeySpec) -> np.ndarray:
    """How far each pad cell travels from the open finger to its first surface point.

    rows : (q,) int64        grasp (0 .. count-1) of each point
    points_g : (q, 3) float  gripper-frame points inside the closing region
    returns : (count, 2, a c) float64, inf where a cell holds no point
    """
    a, c = spec.pad_cells
    _, width, height = spec.region
    points_g = np.asarray(points_g, dtype=np.float64).reshape(-1, 3)
    rows = np.asarray(rows, dtype=np.int64).reshape(-1)
    if len(rows) != len(points_g):
        raise ValueError(f"rows has {len(rows)} entries for {len(points_g)} points")
    i = np.clip(np.floor(points_g[:, 0] / spec.cell).astype(np.int64), 0, a - 1)
    k = np.clip(np.floor((points_g[:, 2] + height / 2) / spec.cell).astype(np.int64), 0, c - 1)
    cell = i * c + k
    gaps = np.full((count, 2, a * c), np.inf)
    np.minimum.at(gaps, (rows, 0, cell), points_g[:, 1] + width / 2)
    np.minimum.at(gaps, (rows, 1, cell), width / 2 - points_g[:, 1])
    return gaps


def contact_keys(rows: np.ndarray, points_g: np.ndarray, count: int, spec: ContactKeySpec) -> np.ndarray:
    """Contact keys of ``count`` crops given as their points (see the module docstring for the layout).

    rows : (q,) int64        crop (0 .. count-1) of each point
    points_g : (q, 3) float  gripper-frame points inside the closing region
    returns : (count, K) uint8
    """
    gaps = pad_gaps(rows, points_g, count, spec)
    least = gaps.min(axis=2)  # (count, 2) each pad's first contact
    met = np.isfinite(gaps)
    relief = np.where(met, gaps - np.where(np.isfinite(least), least, 0.0)[:, :, None], 0.0)
    levels = np.minimum(np.floor(relief / spec.step), spec.levels - 1).astype(np.uint8)
    cells = np.where(met, levels, np.uint8(spec.levels)).reshape(count, -1)
    opening = spec.region[1] - least.sum(axis=1)
    empty = ~np.isfinite(opening)
    width = np.minimum(np.floor(np.where(empty, 0.0, opening) / spec.width_step), EMPTY_CROP - 1)
    width = np.where(empty, EMPTY_CROP, np.maximum(width, 0)).astype(np.uint8)
    return np.concatenate([cells.astype(np.uint8), width[:, None]], axis=1)


def turned_keys(keys: np.ndarray, spec: ContactKeySpec) -> np.ndarray:
    """The keys the same crops give after the gripper's 180-degree turn about u, ``(v, t) -> (-v, -t)``: the pads
    swap and each pad's t cells reverse; the opening stays. keys : (n, K) uint8 -> (n, K) uint8."""
    a, c = spec.pad_cells
    cells = keys[:, :-1].reshape(len(keys), 2, a, c)[:, ::-1, :, ::-1].reshape(len(keys), -1)
    return np.concatenate([cells, keys[:, -1:]], axis=1)


def canonical_keys(keys: np.ndarray, spec: ContactKeySpec) -> np.ndarray:
    """Of each key and its turned twin, the one whose bytes compare smaller. keys : (n, K) uint8 -> (n, K) uint8."""
    keys = np.asarray(keys, dtype=np.uint8)
    return bytewise_smaller(keys, turned_keys(keys, spec))
