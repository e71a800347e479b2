"""The label's own ceiling from repeated draws (issue 51, item 3): a deterministic label reaches 1, pure noise stays
at its floor, a label with per-grasp probabilities lands between."""

import numpy as np
import pytest

from onepiece_dist.stats.ceiling import label_ceiling


def test_the_ceiling_of_a_deterministic_label_is_one():
    rng = np.random.default_rng(0)
    draws = np.repeat((rng.random(500) < 0.3)[:, None], 4, axis=1)
    ceiling = label_ceiling(draws)
    assert (ceiling.agreement, ceiling.ceiling_ap) == (1.0, 1.0)
    assert ceiling.positive_rate == pytest.approx(draws.mean())
    assert ceiling.share_of_way(ceiling.positive_rate) == 0.0 and ceiling.share_of_way(1.0) == 1.0


def test_a_label_of_pure_noise_has_its_ceiling_at_its_floor():
    draws = np.random.default_rng(1).random((4000, 4)) < 0.3
    ceiling = label_ceiling(draws)
    assert ceiling.ceiling_ap == pytest.approx(ceiling.positive_rate, abs=0.02)
    assert ceiling.agreement == pytest.approx(0.3**2 + 0.7**2, abs=0.02)


def test_a_label_with_per_grasp_odds_lies_between_and_its_estimate_never_flatters_it():
    """Leave-one-out scores from few draws rank worse than the true odds: the estimate is conservative and rises
    towards the true ceiling (ranking by the odds themselves) as draws are added."""
    from onepiece_dist.stats.ceiling import threshold_ap

    rng = np.random.default_rng(2)
    p = rng.random(3000)
    few, many = (label_ceiling(rng.random((3000, r)) < p[:, None]) for r in (3, 12))
    true = np.mean([threshold_ap(p, rng.random(3000) < p) for _ in range(20)])
    assert few.positive_rate + 0.1 < few.ceiling_ap < many.ceiling_ap < true + 0.01
    assert many.ceiling_ap == pytest.approx(true, abs=0.06)
    with pytest.raises(ValueError, match="at least 2 draws"):
        label_ceiling(np.ones((5, 1), bool))


def test_the_fitted_ceiling_finds_the_odds_ceiling_from_three_draws_and_keeps_both_ends():
    """Ranking by the true odds is the ceiling; three draws per grasp are too coarse to show it directly (the
    leave-one-out figure stays well below), but the odds' spread fitted to their counts finds it."""
    from onepiece_dist.stats.ceiling import ap_against_draws, fitted_ceiling, threshold_ap

    rng = np.random.default_rng(3)
    for odds in (rng.random(3000), rng.beta(0.5, 2.0, 3000)):
        draws = rng.random((3000, 3)) < odds[:, None]
        true = np.mean([threshold_ap(odds, rng.random(3000) < odds) for _ in range(20)])
        ceiling = label_ceiling(draws)
        assert ceiling.fitted_ap == pytest.approx(true, abs=0.04) and ceiling.ceiling_ap < true - 0.1
        assert ap_against_draws(odds, draws) == pytest.approx(true, abs=0.03)  # the odds against these draws
    assert fitted_ceiling(np.repeat((rng.random(400) < 0.3)[:, None], 3, axis=1)) == 1.0
    noise = rng.random((4000, 3)) < 0.3
    assert fitted_ceiling(noise) == pytest.approx(noise.mean(), abs=0.02)


def true_ceiling(density) -> float:
    """The ceiling of odds distributed as ``density`` on (0, 1): ranking by the odds, many grasps."""
    from onepiece_dist.stats.ceiling import odds_ap

    grid = (np.arange(20_000) + 0.5) / 20_000
    return odds_ap(grid, density(grid))


@pytest.mark.parametrize("name", ["uniform", "beta(0.5, 2)"])
def test_the_measured_ceiling_of_known_odds_holds_the_true_ceiling_in_its_interval(name):
    """Issue 58: 16 draws on 256 grasps measure the ceiling: the true one (ranking by the known odds) lies in the
    measured interval, which is a few points wide; the moment fit's range is reported beside it."""
    from onepiece_dist.stats.ceiling import measured_ceiling

    rng = np.random.default_rng(7)
    draw_odds, density = {"uniform": (lambda n: rng.random(n), np.ones_like),
                          "beta(0.5, 2)": (lambda n: rng.beta(0.5, 2.0, n),
                                           lambda x: x ** -0.5 * (1 - x))}[name]
    odds = draw_odds(256)
    measured = measured_ceiling(rng.random((256, 16)) < odds[:, None])
    truth = true_ceiling(density)
    assert measured.low <= truth <= measured.high, (truth, measured)
    assert measured.high - measured.low < 0.2 and measured.low <= measured.ap <= measured.high
    assert measured.moment_range[0] <= measured.moment_range[1] and measured.positive_rate < measured.low


def test_the_measured_ceiling_keeps_both_ends_and_asks_for_enough_draws():
    from onepiece_dist.stats.ceiling import measured_ceiling

    rng = np.random.default_rng(8)
    deterministic = measured_ceiling(np.repeat((rng.random(200) < 0.3)[:, None], 16, axis=1))
    assert deterministic.ap == pytest.approx(1.0) and deterministic.low > 0.95
    noise = measured_ceiling(rng.random((256, 16)) < 0.3)
    assert noise.low <= 0.3 <= noise.high and noise.ap < 0.35  # the odds 0.3 for every grasp: AP 0.3
    with pytest.raises(ValueError, match="at least 8 draws"):
        measured_ceiling(np.ones((5, 3), bool))


def test_a_study_ceiling_is_measured_where_the_study_drew_enough_and_places_the_arms_against_it():
    from onepiece_dist.study.runner import ceiling_of

    rng = np.random.default_rng(9)
    odds = rng.random(128)
    many = ceiling_of(np.arange(128), rng.random((128, 16)) < odds[:, None], [])
    few = ceiling_of(np.arange(128), rng.random((128, 3)) < odds[:, None], [])
    assert many.measured_ap is not None and many.measured_interval[0] <= many.measured_ap <= many.measured_interval[1]
    assert many.ceiling == many.measured_ap and many.share_of_way(many.measured_ap) == pytest.approx(1.0)
    assert few.measured_ap is None and few.ceiling == few.fitted_ap


def test_an_arms_ensemble_and_its_single_networks_are_reported_apart():
    """Two networks whose errors cancel: their averaged scores rank the draws better than either alone, and the
    ceiling keeps both figures (issue 58: single networks and ensembles apart)."""
    from onepiece_dist.learn.metrics import CurvePoint, Validation
    from onepiece_dist.learn.train import StepResult
    from onepiece_dist.stats.ceiling import ap_against_draws
    from onepiece_dist.study.runner import ceiling_of
    from onepiece_dist.study.training import ArmRun

    rng = np.random.default_rng(3)
    odds = rng.random(200)
    draws = rng.random((200, 8)) < odds[:, None]
    error = rng.normal(0, 0.5, 200)
    seeds = [odds + error, odds - error]

    def result(scores):
        return StepResult(scores, (CurvePoint(1, Validation(0.5, 0.5, 0.5, 0.5)),), 1, 0.0, 0, 0, "cpu")

    trained = [(ArmRun("A", seed, 1e-3, None), result(s)) for seed, s in enumerate(seeds)]  # run: not read
    ceiling = ceiling_of(np.arange(200), draws, trained)
    alone = [ap_against_draws(s, draws) for s in seeds]
    assert ceiling.single_ap["A"] == pytest.approx(np.mean(alone), abs=1e-4)
    assert ceiling.arm_ap["A"] == pytest.approx(ap_against_draws(odds, draws), abs=1e-4)
    assert ceiling.arm_ap["A"] > ceiling.single_ap["A"] + 0.02
