"""The study on pick labels (issue 58): its arms, its draws of the pick label, its decision words and its page."""

import numpy as np
import pytest

from onepiece_dist.study.pick_study.arms import crop_codes, one_per_shape, pick_arms, random_rows
from onepiece_dist.study.picks import paired_verdict

GRID, RES = (4, 8, 2), 0.01


def codes_of(bits: list[list[int]]) -> np.ndarray:
    occupancy = np.zeros((len(bits), 64), bool)
    for row, on in enumerate(bits):
        occupancy[row, on] = True
    return np.packbits(occupancy, axis=1, bitorder="big")


def test_a_crop_sets_the_voxel_its_points_fall_in_and_ignores_points_outside_the_closing_region():
    from onepiece_dist.core.voxel import voxel_indices

    inside = np.zeros((1, 3))  # the closing region's centre
    voxel = int(voxel_indices(inside, GRID, RES)[0])
    assert voxel >= 0
    points = np.stack([np.repeat(inside, 4, axis=0), np.full((4, 3), 5.0)])  # a crop inside, a crop far away
    codes = crop_codes(points, GRID, RES)
    bits = np.unpackbits(codes, axis=1, bitorder="big")
    assert bits[0].sum() == 1 and bits[0, voxel] == 1
    assert bits[1].sum() == 0


def test_b_labels_one_grasp_per_shape_and_merges_shapes_within_its_radius():
    codes = codes_of([[1], [1], [2, 3], [2, 3], [2, 3], [40], [40, 41]])
    exact = one_per_shape(codes, 0, seed=0)
    assert len(exact) == 4  # {1}, {2,3}, {40}, {40,41}
    assert len({codes[r].tobytes() for r in exact}) == 4
    merged = one_per_shape(codes, 1, seed=0)
    assert len(merged) == 3  # {40} and {40,41} differ in one voxel: one shape at radius 1
    assert np.array_equal(exact, one_per_shape(codes, 0, seed=0))
    seen = {tuple(one_per_shape(codes, 0, seed=s)) for s in range(20)}
    assert len(seen) > 1, "the grasp that stands for a shape is drawn, not always the first"


def test_the_arms_are_a_every_label_r_random_shares_and_b_with_r_of_its_size():
    rng = np.random.default_rng(0)
    codes = codes_of([list(rng.choice(12, rng.integers(1, 4), replace=False)) for _ in range(300)])
    arms = {arm.name: arm for arm in pick_arms(codes, (50, 100, 5000), (0, 1), seed=3)}
    assert list(arms) == ["A", "R 50", "R 100", "B r0", "R ~B r0", "B r1", "R ~B r1"]  # 5,000 is above A
    assert np.array_equal(arms["A"].rows, np.arange(300))
    for name, arm in arms.items():
        assert np.all(np.diff(arm.rows) > 0) and arm.rows.max() < 300, name
    assert arms["R ~B r1"].labels == arms["B r1"].labels < arms["B r0"].labels == arms["R ~B r0"].labels
    assert np.array_equal(random_rows(300, 50, 3), arms["R 50"].rows)
    assert not np.array_equal(random_rows(300, 50, 4), arms["R 50"].rows)


def test_equal_per_object_rates_are_a_tie_and_a_clear_gap_is_not():
    rates = np.linspace(0.2, 0.9, 16)
    assert paired_verdict(rates, rates.copy(), 0, 1000, 0.95) == "ties"
    assert paired_verdict(rates + 0.2, rates, 0, 1000, 0.95) == "beats"
    assert paired_verdict(rates, rates + 0.2, 0, 1000, 0.95) == "loses"


def _result(a_rate: float, b_verdict: str = "ties"):
    from onepiece_dist.study.pick_study.result import PickStudyResult

    def arm(name, kind, labels, rate, radius=None):
        per_object = [rate] * 4
        m = {"mean": rate, "std": 0.01, "interval": [rate - 0.1, min(rate + 0.1, 1.0)]}
        return {"name": name, "kind": kind, "radius": radius, "labels": labels, "label_core_seconds": labels * 0.05,
                "fit_seconds": [1.0, 2.0], "checkpoints": ["a.pt", "b.pt"], "ap_single": 0.5, "ap_ensemble": 0.55,
                "picks": {"household": {"first_attempt": m, "per_object": per_object, "per_seed": [rate, rate]}}}

    random = {"mean": 0.3, "std": 0.0, "interval": [0.2, 0.4]}
    return PickStudyResult.model_validate({
        "command": "test", "date": "2026-12-04", "machine": "test", "design": {"name": "context_balanced"},
        "labels": {"rows": 1000, "objects": 10, "success_rate": 0.25, "core_seconds": 50.0, "sources": ["x"]},
        "sets": [{"name": "household", "what": "test views", "chosen_on": True, "objects": 4, "views": 8,
                  "random": random, "separable": True}],
        "arms": [arm("A", "A", 1000, a_rate), arm("R 100", "R", 100, 0.5), arm("B r0", "B", 400, 0.7, 0),
                 arm("R ~B r0", "R", 400, 0.7)],
        "b_versus_random": {"household": {"B r0": b_verdict}},
        "ceiling": {"set": "household", "grasps": 16, "draws": 16, "positive_rate": 0.25, "agreement": 0.8,
                    "ap": 0.75, "low": 0.7, "high": 0.8, "moment_range": [0.6, 0.8]}})


@pytest.mark.parametrize(("a_rate", "verdict"), [(0.84, "met"), (0.62, "**not met**")])
def test_the_page_answers_first_with_a_against_its_target_the_levels_and_the_ceiling(a_rate, verdict):
    from onepiece_dist.study.pick_study.page import page_text

    page = page_text(_result(a_rate))
    head = page.split("## Arms")[0]
    assert f"A at or above 80.0%: {verdict}." in head
    assert "B r0 ties with random labels of its size" in head
    assert "**Labels to reach a pick level**" in head and "| 80.0% |" in head
    assert "**0.750 [0.700, 0.800]**" in head  # the measured ceiling with its interval
    assert "A's networks reach AP 0.500 one at a time" in head and "as an ensemble" in head


def test_the_committed_pick_label_study_is_its_rendering():
    from pathlib import Path

    from onepiece_dist.study.pick_study.page import page_text, read_result

    folder = Path(__file__).resolve().parents[1] / "docs" / "studies" / "pick_labels"
    if not (folder / "study.json").is_file():
        pytest.fail("docs/studies/pick_labels/study.json is missing: run benchmarks/experiments/pick_study.py")
    assert (folder / "study.md").read_text() == page_text(read_result(folder)), \
        "docs/studies/pick_labels/study.md is stale: run `python -m benchmarks.pages.report`"


def test_a_candidates_draws_are_the_same_whatever_else_was_asked(tmp_path):
    from onepiece_dist.picks.draws import run_candidate_draws
    from onepiece_dist.specs.plan import PickSpec

    checkpoint = "onepiece_dist/plan/networks/pick_view.pt"
    spec = PickSpec(objects="pybullet:random_urdfs[500:501]", checkpoint=checkpoint, output=str(tmp_path),
                    views=1, attempts=1, methods=("network",), pictures=0)
    three = run_candidate_draws(spec, (checkpoint,), 2, 3)[0]
    again = run_candidate_draws(spec, (checkpoint,), 1, 2)[0]
    assert three.status == "ok" and len(three.draws) == 2 and all(len(d) == 3 for d in three.draws)
    # asked for fewer, the sample is a part of the larger one (the seeded permutation's first, index-sorted), and
    # each candidate in both meets the same draws and scores
    assert len(again.candidates) == 1 and again.candidates[0] in three.candidates
    k = three.candidates.index(again.candidates[0])
    assert again.draws[0] == three.draws[k][:2] and again.scores[0] == three.scores[k]
