"""The key study's measures (study.lookup) on synthetic keys, study.keys' occupancy codes against core.voxel's,
and the committed key-study pages rendered from their committed results. The key study itself is now a study
option (`keys`, examples/studies/key_study.yaml; tests/test_study.py runs it on the tiny study)."""

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.core.mesh import box_mesh, sample_surface
from onepiece_dist.core.voxel import crop_regions
from onepiece_dist.stats import selection

ROOT = Path(__file__).resolve().parents[1]
lookup = importlib.import_module("onepiece_dist.study.lookup")
page = importlib.import_module("benchmarks.pages.key_study_page")


def keys(values) -> np.ndarray:
    """(n, 1) uint8 keys from (n,) small integers."""
    return np.asarray(values, dtype=np.uint8)[:, None]


def test_a_key_that_decides_the_label_transfers_it_exactly_to_every_held_out_grasp_it_covers():
    train = np.arange(40) % 8
    test = np.r_[np.arange(24) % 8, [9, 9, 10]]  # three held-out grasps with keys no train grasp has
    label = lambda k: k % 2 == 0  # noqa: E731
    out = lookup.lookup_transfer(keys(train), label(train), keys(test), label(test))
    assert out.covered == 24 and out.coverage == pytest.approx(24 / 27, abs=1e-4)
    assert out.one_label.agreement == out.majority.agreement == 1.0
    assert out.one_label.floor == 0.5


def test_a_key_that_ignores_the_label_agrees_about_as_often_as_the_floor():
    rng = np.random.default_rng(0)
    train, test = rng.integers(0, 20, 4000), rng.integers(0, 20, 4000)
    out = lookup.lookup_transfer(keys(train), rng.random(4000) < 0.4, keys(test), rng.random(4000) < 0.4)
    assert out.coverage == 1.0
    assert out.one_label.agreement == pytest.approx(out.one_label.floor, abs=0.03)


def test_one_label_per_key_agrees_as_its_keys_positive_fraction_expects_and_the_majority_outvotes_it():
    train, success = keys([1, 1, 1, 2, 2]), np.array([False, True, True, True, False])
    out = lookup.lookup_transfer(train, success, keys([1, 2, 1]), np.array([True, True, False]))
    # key 1 is positive in 2 of 3 train grasps, key 2 in 1 of 2: expected agreement (2/3 + 1/2 + 1/3) / 3
    assert out.one_label.agreement == pytest.approx(1.5 / 3, abs=1e-4)
    assert out.majority.agreement == pytest.approx(1 / 3, abs=1e-4)  # key 1 positive, key 2 a tie: negative


def test_one_grasp_per_key_is_drawn_among_each_keys_own_grasps_and_reaches_every_one_of_them():
    inverse = np.array([0, 0, 0, 1, 2, 2])
    rng = np.random.default_rng(5)
    drawn = np.array([selection.one_grasp_per_key(inverse, rng) for _ in range(200)])
    assert np.array_equal(inverse[drawn], np.broadcast_to(np.arange(3), drawn.shape))
    assert set(drawn[:, 0]) == {0, 1, 2} and set(drawn[:, 1]) == {3} and set(drawn[:, 2]) == {4, 5}
    sparse = selection.one_grasp_per_key(np.array([4, 1, 4]), rng)  # keys 0, 2, 3 have no row: none for them
    assert sparse[0] == 1 and sparse[1] in (0, 2) and len(sparse) == 2


def test_the_share_decided_runs_from_zero_at_the_floor_to_one_at_the_ceiling():
    assert lookup.decided_share(lookup.Agreement(0.5, 0.5), 0.8) == 0.0
    assert lookup.decided_share(lookup.Agreement(0.8, 0.5), 0.8) == 1.0
    assert lookup.decided_share(lookup.Agreement(0.65, 0.5), 0.8) == 0.5
    assert lookup.decided_share(lookup.Agreement(0.6, 0.6), 0.55) is None
    assert lookup.decided_share(lookup.Agreement(None, None), 0.8) is None


def test_one_label_per_key_ranks_below_as_many_random_labels_where_a_frequent_key_holds_mixed_labels():
    rng = np.random.default_rng(4)
    train_keys = keys(np.r_[np.zeros(300, int), 1 + np.arange(30)])  # key 0: 300 grasps, 75% positive
    train_success = np.r_[rng.random(300) < 0.75, rng.random(30) < 0.3]  # and 30 keys met once
    test_keys = keys(np.r_[np.zeros(200, int), 1 + np.arange(30)])
    test_success = np.r_[rng.random(200) < 0.75, rng.random(30) < 0.3]
    out = lookup.budget_lookup(train_keys, train_success, test_keys, test_success, seed=0, draws=20)
    assert out["B"].labels == out["R"].labels == out["S"].labels == 31 and out["A"].labels == 330
    assert out["B"].coverage == 1.0 > out["R"].coverage
    # B's one label for key 0, wrong a quarter of the time, decides most held-out grasps; R averages ~28 of them
    assert out["R"].ap > out["B"].ap and out["R"].accuracy > out["B"].accuracy
    assert out["B"].sd_accuracy > 3 * out["R"].sd_accuracy


def test_labels_spread_by_key_count_follow_its_root_stay_within_each_key_and_spend_the_budget():
    inverse = np.r_[np.zeros(400, int), np.ones(100, int), 2 + np.arange(50)]  # counts 400, 100, then 50 x 1
    rows = lookup.grasps_by_key_count(inverse, 60, np.random.default_rng(6))
    assert len(rows) == len(set(rows.tolist())) == 60
    taken = np.bincount(inverse[rows], minlength=52)
    # quotas 60 * sqrt(c) / (20 + 10 + 50) = 15, 7.5 and 0.75 each: largest remainders give 15, 8 and 37 singles
    assert taken[0] == 15 and taken[1] in (7, 8) and taken[2:].sum() == 60 - taken[0] - taken[1]
    assert taken.max() <= np.bincount(inverse).max()
    capped = lookup.grasps_by_key_count(np.array([0, 1, 1, 1]), 4, np.random.default_rng(0), power=1.0)
    assert sorted(capped.tolist()) == [0, 1, 2, 3]


def test_a_key_that_decides_the_label_ranks_perfectly_from_one_label_per_key():
    train, test = np.arange(80) % 8, np.arange(40) % 8
    out = lookup.budget_lookup(keys(train), train % 2 == 0, keys(test), test % 2 == 0, seed=0)
    assert out["A"].ap == out["B"].ap == 1.0 and out["B"].accuracy == 1.0 and out["B"].sd_ap == 0


def test_occupancy_codes_from_the_kept_crop_points_are_the_codes_core_voxel_gives():
    from onepiece_dist.study.keys import Crops, key_of
    from onepiece_dist.study.spec import StudyKey

    mesh = box_mesh((0.05, 0.03, 0.04))
    cloud = sample_surface(mesh, 3000, np.random.default_rng(1))[0]
    poses = np.repeat(np.eye(4)[None], 3, axis=0)
    poses[:, 0, 3] = [-0.03, -0.02, -0.035]  # palm behind the box along u; the region holds part of it
    poses[2, :3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # turned about u
    codes, counts, kept = crop_regions(cloud, poses, (4, 8, 2), 0.01, keep_points=True)
    crops = Crops(np.concatenate(kept), np.repeat(np.arange(3), counts), 3)
    region = (0.04, 0.08, 0.02)
    assert counts.min() > 0
    assert np.array_equal(key_of(crops, StudyKey(name="10 mm", kind="occupancy", resolution=0.01), region), codes)
    both = key_of(crops, StudyKey(name="both", kind="both", resolution=0.01, cell=0.02, step=0.004, levels=3,
                                  width_step=0.01), region)
    assert both.shape == (3, 8 + 5) and np.array_equal(both[:, :8], codes)


def row(name: str, unique: float, coverage: float, share: float) -> dict:
    return {"key": name, "unique_fraction": unique, "lookup": {"coverage": coverage},
            "decided_share_one_label": share}


@pytest.mark.parametrize("unique, coverage, share, dominates", [
    (0.2, 0.8, 0.5, True), (0.3, 0.8, 0.5, False), (0.2, 0.6, 0.5, False), (0.2, 0.8, 0.3, False)])
def test_a_key_beats_the_experiments_code_only_if_it_repeats_as_much_covers_as_much_and_decides_more(
        unique, coverage, share, dominates):
    out = {"keys": [row(page.REFERENCE, 0.25, 0.7, 0.4), row("contact", unique, coverage, share)]}
    assert [r["key"] for r in page.dominating(out)] == (["contact"] if dominates else [])


def test_an_arm_ranks_above_another_only_by_more_than_their_spreads_added():
    assert page.beyond_spreads({"ap": 0.53, "sd": {"ap": 0.01}}, {"ap": 0.50, "sd": {"ap": 0.01}})
    assert not page.beyond_spreads({"ap": 0.445, "sd": {"ap": 0.019}}, {"ap": 0.422, "sd": {"ap": 0.038}})
    assert page.beyond_spreads({"ap": 0.52, "sd": {"ap": 0.01}}, {"ap": 0.50})  # one run: no spread of its own


def test_the_committed_page_is_the_rendering_of_the_committed_results(tmp_path):
    committed = sorted((ROOT / "benchmarks" / "results").glob("key_study*.json"))
    assert [path.stem for path in committed] == ["key_study", "key_study_object_load"]  # none may go missing
    for results in committed:
        out = json.loads(results.read_text())
        assert not out["quick"] and out["name"] == results.stem
        page.write_page(out, tmp_path / "page.md")
        assert (ROOT / "docs" / f"{results.stem}.md").read_text() == (tmp_path / "page.md").read_text(), \
            f"docs/{results.stem}.md is stale: render its results (benchmarks/pages/key_study_page.py)"
        assert (ROOT / "docs" / f"{results.stem}.png").stat().st_size > 1000
