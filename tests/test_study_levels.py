"""Issue 58: per plan, the labels and core-seconds to reach a pick level, read off its measured pick curve."""

from pathlib import Path

from onepiece_dist.study.levels import RANDOM_PLAN, PlanPoint, level_readings, levels_lines, plan_curves, reach
from onepiece_dist.study.result import Measure, StudyResult

ROOT = Path(__file__).resolve().parents[1]


def point(arm: str, labels: int, mean: float, low: float, high: float) -> PlanPoint:
    return PlanPoint(arm, labels, labels / 10, Measure(mean=mean, std=0.0, interval=(low, high)))


CURVE = [point("R 0.1", 100, 0.40, 0.30, 0.50), point("R 0.3", 400, 0.60, 0.50, 0.70),
         point("A", 1600, 0.75, 0.70, 0.80)]


def test_a_level_is_read_off_the_curve_at_the_fewest_labels_whose_mean_reaches_it_with_its_range():
    half = reach(RANDOM_PLAN, CURVE, 0.5)
    assert (half.arm, half.labels, half.core_seconds) == ("R 0.3", 400, 40.0)
    assert (half.possibly, half.surely) == (100, 400)  # 100's interval reaches 50%; 400's lies at or above it
    high = reach(RANDOM_PLAN, CURVE, 0.72)
    assert (high.arm, high.possibly, high.surely) == ("A", 1600, None)  # no measured size lies wholly above 72%
    unreached = reach(RANDOM_PLAN, CURVE, 0.8)
    assert unreached.arm is None and unreached.labels is None and unreached.possibly == 1600
    assert unreached.best.arm == "A"


def test_the_committed_picks_study_says_per_plan_what_each_level_costs_and_which_it_does_not_reach():
    result = StudyResult.model_validate_json((ROOT / "docs" / "studies" / "picks" / "study.json").read_text())
    curves = plan_curves(result)
    arms = {arm.name: arm for arm in result.arms}
    assert set(curves) == {RANDOM_PLAN} | {a.name for a in result.arms if a.kind not in ("A", "R")}
    assert {p.arm for p in curves[RANDOM_PLAN]} == {a.name for a in result.arms if a.kind in ("A", "R")}
    a = next(p for p in result.picks.arms if p.name == "A").first_attempt.mean
    readings = level_readings(result)
    assert {r.level for r in readings} >= {0.5, 0.8, round(a, 4)}
    for r in readings:
        points = curves[r.plan]
        if r.arm is None:  # not reached: no measured point's mean reaches the level
            assert all(p.picks.mean < r.level for p in points)
        else:  # reached by its mean, at no more labels than any other point that reaches it, at its own cost
            assert next(p for p in points if p.arm == r.arm).picks.mean >= r.level
            assert r.labels == min(p.labels for p in points if p.picks.mean >= r.level)
            assert r.core_seconds == arms[r.arm].cost.core_seconds and r.possibly <= r.labels
    lines = levels_lines(result)
    assert lines[1].startswith("**Labels to reach a pick level**")
    rows = [line for line in lines if line.startswith("| ") and not line.startswith("| ---")]
    assert len(rows) == 1 + len({r.level for r in readings})  # the plans' header, then a row per level
    assert sum(line.count("not reached") for line in lines) == sum(r.arm is None for r in readings)
