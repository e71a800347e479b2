"""A uniform-grid index of points for box queries, so per-patch checks on the one object cost what is near the
patch, not the whole object (pure numpy)."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.frames import transform_points


class PointGrid:
    """Points (n, 3) float binned into cubic cells of edge ``cell`` (m), sorted by cell."""

    def __init__(self, points: np.ndarray, cell: float):
        self.points = np.asarray(points)
        self.cell = float(cell)
        self.order, self.sorted_cells = self._sort_by_cell()

    def _sort_by_cell(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell index of every point, one axis at a time (the one object holds tens of millions of points: no
        (n, 3) temporaries); -> (order (n,) int32 or int64, sorted cell indices (n,) int64)."""
        n = len(self.points)
        if n == 0:
            self.origin, self.dims = np.zeros(3, np.int64), np.ones(3, np.int64)
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        low = np.floor(self.points.min(axis=0) / self.cell).astype(np.int64)  # floor is monotonic: the lowest key
        high = np.floor(self.points.max(axis=0) / self.cell).astype(np.int64)
        self.origin, self.dims = low, high - low + 1
        flat = np.zeros(n, dtype=np.int64)
        for axis in range(3):
            flat *= self.dims[axis]
            flat += np.floor(self.points[:, axis] / self.cell).astype(np.int64) - low[axis]
        order = np.argsort(flat, kind="stable")
        flat = flat[order]  # the unsorted keys go now, not after the int32 copy below
        return (order.astype(np.int32) if n < 2**31 else order), flat

    def in_box(self, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
        """(m,) int64 indices of the points with lower <= p <= upper (every coordinate)."""
        lo = np.floor(np.asarray(lower) / self.cell).astype(np.int64) - self.origin
        hi = np.floor(np.asarray(upper) / self.cell).astype(np.int64) - self.origin
        if len(self.points) == 0 or np.any(hi < 0) or np.any(lo >= self.dims):
            return np.zeros(0, dtype=np.int64)
        lo, hi = np.maximum(lo, 0), np.minimum(hi, self.dims - 1)
        ix, iy = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij")
        first = (ix.ravel() * self.dims[1] + iy.ravel()) * self.dims[2]
        starts = np.searchsorted(self.sorted_cells, first + lo[2], side="left")
        ends = np.searchsorted(self.sorted_cells, first + hi[2], side="right")
        candidates = self.order[_ranges(starts, ends)]
        inside = np.all((self.points[candidates] >= lower) & (self.points[candidates] <= upper), axis=1)
        return candidates[inside].astype(np.int64)


def _ranges(starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s, e) for each pair, vectorized."""
    lengths = np.maximum(ends - starts, 0)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.repeat(starts - np.cumsum(lengths) + lengths, lengths)
    return offsets + np.arange(total)


def box_corners(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(8, 3) corners of an axis-aligned box."""
    return np.array([[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])
                     for z in (lower[2], upper[2])])


def posed_box_bounds(lower: np.ndarray, upper: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds in the object frame of a box given in a frame posed by ``pose`` (4, 4)."""
    corners = transform_points(box_corners(lower, upper), pose)  # fixed-order, as the crops that use them
    return corners.min(axis=0), corners.max(axis=0)
