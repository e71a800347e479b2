"""Convex pieces clipped to the patch box: exact polytopes."""

import numpy as np
import pytest

from onepiece_dist.core.clip import clip_to_box


def as_set(points: np.ndarray) -> set:
    return {tuple(p) for p in np.round(points, 9)}


def box_corners(lower, upper) -> np.ndarray:
    return np.array([[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1])
                     for z in (lower[2], upper[2])], dtype=float)


def test_a_box_clipped_by_a_box_is_their_intersection_box():
    piece = box_corners((-0.01, -0.02, -0.03), (0.01, 0.02, 0.03))
    clipped = clip_to_box(piece, np.array([0.0, -0.01, -0.05]), np.array([0.05, 0.01, 0.01]))
    assert as_set(clipped) == as_set(box_corners((0.0, -0.01, -0.03), (0.01, 0.01, 0.01)))


def test_a_cylinder_hull_clipped_across_its_axis_keeps_its_ring_and_gains_the_cut_edges():
    n, radius, half_height, cut = 16, 0.02, 0.03, 0.012
    angles = 2 * np.pi * np.arange(n) / n
    ring = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    piece = np.vstack([np.c_[ring, np.full(n, z)] for z in (-half_height, half_height)])
    clipped = clip_to_box(piece, np.array([-cut, -1, -1]), np.array([cut, 1, 1]))
    kept = ring[np.abs(ring[:, 0]) <= cut]
    crossings = []  # where the polygon's edges cross x = +-cut
    for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        for level in (-cut, cut):
            if (a[0] - level) * (b[0] - level) < 0:
                t = (level - a[0]) / (b[0] - a[0])
                crossings.append(a + t * (b - a))
    section = np.vstack([kept, crossings])
    expected = np.vstack([np.c_[section, np.full(len(section), z)] for z in (-half_height, half_height)])
    assert as_set(clipped) == as_set(expected)
    assert np.all(np.abs(clipped[:, 0]) <= cut + 1e-12)


def test_a_piece_outside_the_box_or_only_touching_it_gives_nothing():
    piece = box_corners((0.1, 0.1, 0.1), (0.2, 0.2, 0.2))
    assert clip_to_box(piece, np.zeros(3), np.full(3, 0.05)).shape == (0, 3)
    assert clip_to_box(piece, np.zeros(3), np.full(3, 0.1)).shape == (0, 3)  # one corner touches


@pytest.mark.parametrize("seed", range(5))
def test_clipped_points_lie_in_the_box_and_the_inner_points_are_kept(seed):
    rng = np.random.default_rng(seed)
    piece = rng.normal(0, 0.02, (32, 3))
    lower, upper = np.array([-0.01, -0.015, -0.02]), np.array([0.02, 0.01, 0.005])
    clipped = clip_to_box(piece, lower, upper)
    assert np.all((clipped >= lower - 1e-12) & (clipped <= upper + 1e-12))
    inside = piece[np.all((piece > lower) & (piece < upper), axis=1)]
    assert as_set(inside) <= as_set(clipped)


def reference_hull_2d(points: np.ndarray) -> np.ndarray:
    """Andrew's monotone chain over every point, as clip.py had it before the interior filter."""
    _, unique = np.unique(np.round(points, 12), axis=0, return_index=True)
    order = unique[np.lexsort((points[unique, 1], points[unique, 0]))]

    def chain(indices):
        hull = []
        for i in indices:
            while len(hull) >= 2 and ((points[hull[-1], 0] - points[hull[-2], 0]) * (points[i, 1] - points[hull[-2], 1])
                                      - (points[hull[-1], 1] - points[hull[-2], 1])
                                      * (points[i, 0] - points[hull[-2], 0])) <= 0:
                hull.pop()
            hull.append(int(i))
        return hull

    return np.array(chain(order)[:-1] + chain(order[::-1])[:-1])


@pytest.mark.parametrize("seed", range(6))
def test_the_2d_hull_skips_inner_points_and_gives_the_same_vertices(seed):
    from onepiece_dist.core.clip import _hull_2d

    rng = np.random.default_rng(seed)
    points = rng.uniform(-0.02, 0.02, (400, 2))
    points = np.vstack([points, points[:20], [[-0.03, 0.0], [-0.03, 0.01], [-0.03, -0.01]]])  # duplicates, collinear
    if seed % 2:
        points = np.round(points, 3)  # a grid: many collinear points on the hull
    assert np.array_equal(_hull_2d(points), reference_hull_2d(points))


@pytest.mark.parametrize("seed", range(4))
def test_pieces_whose_bounds_miss_the_box_are_skipped_with_the_result_the_cuts_give(seed, monkeypatch):
    import onepiece_dist.core.clip as clip

    rng = np.random.default_rng(seed)
    lower, upper = np.array([-0.01, -0.015, -0.02]), np.array([0.02, 0.01, 0.005])
    pieces = [rng.normal(rng.uniform(-0.06, 0.06, 3), 0.01, (24, 3)) for _ in range(40)]
    fast = [clip_to_box(piece, lower, upper) for piece in pieces]
    monkeypatch.setattr(clip, "MISS", np.inf)  # no bounds check: every piece through all six cuts
    for piece, quick in zip(pieces, fast, strict=True):
        assert np.array_equal(clip_to_box(piece, lower, upper), quick)
    missed = sum(np.any(p.min(0) > upper + 1e-9) or np.any(p.max(0) < lower - 1e-9) for p in pieces)
    assert 0 < missed < len(pieces)  # both kinds were drawn


@pytest.mark.parametrize("seed", range(6))
def test_the_first_of_equal_rows_are_the_rows_numpy_unique_picks(seed):
    from onepiece_dist.core.clip import first_of_equal_rows

    rng = np.random.default_rng(seed)
    for d in (2, 3):
        rows = np.round(rng.normal(size=(rng.integers(0, 300), d)), 1)  # coarse: many equal rows
        rows[rng.random(rows.shape) < 0.1] = -0.0  # signed zeros are equal to zeros, as for np.unique
        rows[rng.random(rows.shape) < 0.1] = 0.0
        expected = np.sort(np.unique(rows, axis=0, return_index=True)[1]) if len(rows) else np.zeros(0, int)
        assert np.array_equal(first_of_equal_rows(rows), expected)
