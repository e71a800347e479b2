"""The pages that ask what orders the network's best grasps (issue 55): a rule is kept only where it raises both
sets, failures are counted by rank and object, and a prior is judged on grasps it was not fitted on."""

from __future__ import annotations

import numpy as np


def _robust_result(unseen_mean: float) -> dict:
    chosen = {"household": {"shipped": 0.80, "mean_x1": 0.82, "near_mean": 0.79},
              "unseen": {"shipped": 0.70, "mean_x1": unseen_mean, "near_mean": 0.72}}
    return {"command": "c", "date": "d", "machine": "m", "seconds": 1.0, "samples": 16, "scales": [1.0],
            "near": {"m": 0.01, "deg": 20.0},
            "sets": {w: {"views": 2, "views_elsewhere": [], "chosen": {n: {"3": v, "10": v} for n, v in c.items()}}
                     for w, c in chosen.items()}}


def test_a_rule_under_pose_noise_is_kept_only_where_it_raises_both_sets():
    from benchmarks.experiments.pick_robust_rank import _rules
    from benchmarks.pages.pick_rank_section import robust_rank_section

    nominal = np.array([0.9, 0.8])
    rules = _rules(nominal, {1.0: np.array([[0.5, 0.7], [0.9, 0.9]])}, np.array([0.6, 0.7]))
    assert np.allclose(rules["mean_x1"], [0.6, 0.9]) and np.allclose(rules["min_x1"], [0.5, 0.9])
    assert np.allclose(rules["near_and_nominal"], [0.75, 0.75]) and rules["shipped"] is nominal
    kept = robust_rank_section(_robust_result(0.75))[-1]
    assert "raising both sets: the mean score of 16 perturbed poses, 1x the protocol's noise (+2.0 / +5.0" in kept
    assert "no rule raises both sets: not kept" in robust_rank_section(_robust_result(0.69))[-1]


def _row(name: str, shares: list[float], signal: list[float], scores: list[float]) -> dict:
    """A view's ranked grasps: 8 draws each picking ``shares`` of the time; a feature ``signal`` beside ``scores``."""
    picked = [[d < round(8 * s) for d in range(8)] for s in shares]
    failures = [["" if p else "slipped_lifting" for p in each] for each in picked]
    features = [[score, sig] + [0.0] * 10 for score, sig in zip(scores, signal, strict=True)]
    return {"object": name, "view": 0, "stored": picked, "picked": picked, "failures": failures,
            "features": features}


def test_failures_are_counted_by_rank_and_object_and_a_prior_is_judged_on_grasps_it_was_not_fitted_on():
    from benchmarks.experiments.pick_rank_features import by_object, chosen_share, failure_table, prior_trial
    from benchmarks.pages.pick_rank_section import rank_features_section

    # the network ranks a weaker grasp first; the second feature says which grasp holds
    rows = {w: [_row(f"{w}{i}", [0.5, 1.0, 0.0], [0.1, 0.9, 0.0], [0.9, 0.8, 0.7]) for i in range(4)]
            for w in ("household", "unseen")}
    assert failure_table(rows["unseen"])["1"] == {"picked": 16, "slipped_lifting": 16}
    assert by_object(rows["unseen"][:1])["unseen0"] == {"first": {"picked": 4, "slipped_lifting": 4},
                                                        "shares": [0.5, 1.0, 1.0]}
    assert chosen_share(rows["unseen"], None, 3) == 0.5
    prior = prior_trial(rows["household"], rows["unseen"])
    assert prior["unseen"]["3"] == [0.5, 1.0] and prior["household_left_out"]["3"] == [0.5, 1.0]
    result = {"command": "c", "date": "d", "machine": "m", "seconds": 1.0, "features": ["score", "signal"],
              "prior": prior, "sets": {w: {"draws_agree": 1.0, "failures": failure_table(r),
                                           "objects": by_object(r)} for w, r in rows.items()}}
    assert rank_features_section(result)[-1].endswith("(+50.0): kept.")
    useless = {w: [_row(f"{w}{i}", [0.5, 1.0, 0.0], [0.0, 0.0, 0.0], [0.9, 0.8, 0.7]) for i in range(4)]
               for w in rows}
    assert prior_trial(useless["household"], useless["unseen"])["unseen"]["3"] == [0.5, 0.5]
