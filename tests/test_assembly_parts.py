"""ONE PIECE assembly without a dataset: the classifier, the layout's corridors, the label agreement, the point
grid and the chamfer distance."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from onepiece_dist.core.assembly_layout import FACES, assembly_geometry, corridor_intrusions, layout_patches, patch_box
from onepiece_dist.core.classifier import PLANES, classify_occupancy, l_feature_count
from onepiece_dist.core.spatial import PointGrid
from onepiece_dist.specs.job import GripperSpec

GRID = (4, 8, 2)


def occupancy(*cells):
    occ = np.zeros((1, *GRID), dtype=bool)
    for cell in cells:
        occ[(0, *cell)] = True
    return occ


def test_l_features_count_windows_with_exactly_three_cells():
    checker = np.array([[[1, 0, 1], [0, 1, 0], [1, 0, 1]]], dtype=bool)  # every window has two cells
    corners = np.array([[[1, 1, 1], [1, 0, 1], [1, 1, 1]]], dtype=bool)  # every window is an L
    full = np.ones((1, 3, 3), dtype=bool)
    assert l_feature_count(checker)[0] == 0 and l_feature_count(corners)[0] == 4 and l_feature_count(full)[0] == 0


def test_a_plane_of_l_corners_wins_over_flat_projections():
    # an L in (v, t) repeated at every u: the vt projection has one L window; uv and ut are filled rectangles
    cells = [(u, v, t) for u in range(4) for v, t in ((3, 0), (4, 0), (3, 1))]
    result = classify_occupancy(occupancy(*cells))
    assert result.features[0].tolist() == [0, 0, 1]
    assert PLANES[result.plane[0]] == "vt"
    assert result.areas[0].tolist() == [8, 8, 3]
    assert result.scores[0, 2] == pytest.approx(3 / 19)


def test_a_flat_patch_has_no_features_and_ties_go_to_the_largest_area():
    flat = occupancy(*[(u, 5, t) for u in range(4) for t in range(2)])  # the plane v = 5
    result = classify_occupancy(flat)
    assert result.features[0].tolist() == [0, 0, 0] and result.areas[0].tolist() == [4, 8, 2]
    assert PLANES[result.plane[0]] == "ut"


def test_equal_scores_and_areas_fall_back_to_plane_order():
    result = classify_occupancy(np.zeros((1, *GRID), dtype=bool))
    assert PLANES[result.plane[0]] == "uv"


def synthetic_patches(count: int, rng) -> tuple[list, list]:
    """Random convex pieces and surface points inside the patch box, as patches of real objects are."""
    lower, upper = patch_box(GripperSpec(), 0.01)
    pieces, points = [], []
    for _ in range(count):
        a, b = np.sort(rng.uniform(lower, upper, (2, 3)), axis=0)
        pieces.append([np.array([[x, y, z] for x in (a[0], b[0]) for y in (a[1], b[1]) for z in (a[2], b[2])])])
        points.append(rng.uniform(a, b, (50, 3)))
    return pieces, points


def test_no_patch_enters_another_patch_gripper_corridor():
    rng = np.random.default_rng(0)
    plane = classify_occupancy(rng.random((60, *GRID)) < 0.4).plane
    gripper = GripperSpec()
    pieces, points = synthetic_patches(60, rng)
    layout = layout_patches(plane, gripper, 0.01)
    geometry = assembly_geometry(layout, pieces, points, 0.01)
    assert corridor_intrusions(geometry["points"], geometry["point_patch"], layout.placements, gripper, 2.0).sum() == 0
    squeezed = layout.placements.copy()  # a tighter grid lets neighbours in: the check can fail
    squeezed[:, :3, 3] *= 0.7
    assert corridor_intrusions(geometry["points"], geometry["point_patch"], squeezed, gripper, 2.0).sum() > 0


def test_the_classifier_decides_where_and_how_a_patch_is_laid():
    gripper = GripperSpec()
    base = layout_patches(np.array([0, 0, 1, 2], dtype=np.int8), gripper, 0.01)
    moved = layout_patches(np.array([0, 2, 1, 2], dtype=np.int8), gripper, 0.01)  # patch 1: uv -> vt
    assert not np.allclose(base.placements[1], moved.placements[1])
    for layout in (base, moved):  # the gripper approaches each patch along the inward normal of its class's face
        for k, cls in enumerate(layout.face):
            assert np.allclose(layout.placements[k][:3, 0], -FACES[cls][0])
            assert np.allclose(layout.placements[k][:3, 1], FACES[cls][1])


def test_agreement_counts_equal_outcomes_and_correlates_qualities():
    from onepiece_dist.job.stages.label_transfer import agreement

    pairs = [((1.0, 1.0), (1.0, 0.75)), ((0.0, 0.0), (1.0, 0.25)), ((1.0, 0.5), (1.0, 0.5))]
    result = agreement(pairs)
    assert result.pairs == 3 and result.success_agreement == pytest.approx(2 / 3, abs=1e-4)
    assert result.quality_correlation == pytest.approx(np.corrcoef([1, 0, 0.5], [0.75, 0.25, 0.5])[0, 1], abs=1e-4)
    constant = agreement([((1.0, 1.0), (1.0, 1.0))] * 2)
    assert constant.success_agreement == 1.0 and constant.quality_correlation is None
    assert agreement([]).pairs == 0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 300), st.floats(0.005, 0.2), st.integers(0, 2**31))
def test_point_grid_box_queries_equal_brute_force(count, cell, seed):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-0.3, 0.3, (count, 3))
    grid = PointGrid(points, cell)
    for _ in range(5):
        lower = rng.uniform(-0.5, 0.3, 3)
        upper = lower + rng.uniform(0, 0.4, 3)
        expected = np.flatnonzero(np.all((points >= lower) & (points <= upper), axis=1))
        assert np.array_equal(np.sort(grid.in_box(lower, upper)), expected)


@pytest.mark.parametrize("rows", [1, 7, 256])
def test_the_chamfer_distance_taken_in_row_blocks_is_the_brute_force_one(rows):
    from onepiece_dist.job.stages.assemble import chamfer_distance

    rng = np.random.default_rng(rows)
    a, b = rng.normal(size=(300, 3)), rng.normal(size=(41, 3)) + 0.5
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2))
    assert chamfer_distance(a, b, rows) == (d.min(axis=1).mean() + d.min(axis=0).mean()) / 2  # to the last bit
    assert chamfer_distance(a, a, rows) == 0.0
