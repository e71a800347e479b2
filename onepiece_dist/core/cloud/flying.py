"""A depth camera's flying pixels, found on its depth image: a pixel that straddles an object's edge mixes the
object's depth with what lies behind it, and back-projected it stands in the air between the two, a veil along the
camera's rays that a planner takes for a surface (docs/picks.md: the network closes on it). Such a pixel lies
inside the depths of its neighbours and fits neither neighbouring surface's continuation; a face seen grazing
steps evenly (it fits its continuation) and a thin rim or handle stands nearer than both its sides (it is not
inside them), so neither is taken for one."""

from __future__ import annotations

import numpy as np

FLYING_TOLERANCE = 0.005  # m: the planner's tolerance where it drops them (PlanSpec.drop_flying)


def flying_mask(depth: np.ndarray, tolerance: float = FLYING_TOLERANCE) -> np.ndarray:
    """(H, W) bool: the pixels of ``depth`` (H, W; metres along the camera's axis, 0, NaN or inf where nothing
    returned) that, along rows or along columns, lie more than ``tolerance`` (m) inside the depths of their 2
    neighbours each side and fit neither neighbouring surface's linear continuation (2 d[i-1] - d[i-2] and
    2 d[i+1] - d[i+2]) within it. A pixel within 2 of one without a return is never flagged."""
    metres = np.where(np.isfinite(depth) & (depth > 0), depth, 0.0).astype(np.float64)
    padded = np.pad(metres, 2)
    rows, cols = metres.shape
    out = np.zeros(metres.shape, dtype=bool)
    for axis in (0, 1):
        def shifted(k: int, axis: int = axis) -> np.ndarray:
            return padded[2 + k:2 + k + rows, 2:-2] if axis == 0 else padded[2:-2, 2 + k:2 + k + cols]

        far_before, near_before, near_after, far_after = (shifted(k) for k in (-2, -1, 1, 2))
        low = np.minimum(np.minimum(far_before, near_before), np.minimum(near_after, far_after))
        high = np.maximum(np.maximum(far_before, near_before), np.maximum(near_after, far_after))
        flagged = (low > 0) & (metres > low + tolerance) & (metres < high - tolerance)  # seen around, inside
        flagged &= np.abs(metres - (2.0 * near_before - far_before)) > tolerance
        out |= flagged & (np.abs(metres - (2.0 * near_after - far_after)) > tolerance)
    return out


def without_flying(depth: np.ndarray, tolerance: float) -> np.ndarray:
    """``depth`` with its flying pixels (flying_mask) set to 0 (no return); unchanged where ``tolerance`` is 0."""
    if tolerance <= 0:
        return depth
    return np.where(flying_mask(depth, tolerance), 0.0, depth)
