"""Labels to reach a pick level (issue 58): per plan, the labels and core-seconds it needs before its networks pick
a given share of the held-out views at the first attempt, read off the plan's measured pick curve with intervals.

A plan is a way to choose what to label: random labels (A and every R arm: random shares of A's candidates, A the
whole) form one curve over label counts; each other arm (B r, B static r, U) is a plan measured at its one size.
For a level, a plan's reading is its fewest-label arm whose mean pick rate reaches the level, and its range: from
the fewest labels whose interval reaches the level (fewer cannot be told apart from it) to the fewest whose
interval lies wholly at or above it (None: no measured size does). Read only from the study's result.
"""

from __future__ import annotations

from dataclasses import dataclass

from onepiece_dist.study.markdown import pct
from onepiece_dist.study.result import Arm, Measure, StudyResult

LEVELS = (0.5, 0.6, 0.7, 0.8)  # first-attempt pick rates asked of every plan, with A's own
RANDOM_PLAN = "random labels (A, R)"


@dataclass(frozen=True)
class PlanPoint:
    arm: str
    labels: int
    core_seconds: float
    picks: Measure


@dataclass(frozen=True)
class LevelReach:
    """One plan at one level: the arm that reaches it by its mean (None: none measured does), and the range of
    label counts its intervals allow (``surely`` None: no measured size lies wholly above the level)."""

    plan: str
    level: float
    arm: str | None
    labels: int | None
    core_seconds: float | None
    possibly: int | None
    surely: int | None
    best: PlanPoint
    largest: int = 0


def plan_curves(result: StudyResult) -> dict[str, list[PlanPoint]]:
    """{plan: its measured points, fewest labels first}; empty when the study was not judged by picks."""
    if result.picks is None:
        return {}
    arms: dict[str, Arm] = {arm.name: arm for arm in result.arms}
    curves: dict[str, list[PlanPoint]] = {}
    for judged in result.picks.arms:
        arm = arms.get(judged.name)
        if arm is None:
            continue
        plan = RANDOM_PLAN if arm.kind in ("A", "R") else arm.name
        curves.setdefault(plan, []).append(PlanPoint(arm.name, arm.cost.labelled_grasps, arm.cost.core_seconds,
                                                     judged.first_attempt))
    return {plan: sorted(points, key=lambda p: (p.labels, p.core_seconds)) for plan, points in curves.items()}


def a_rate(result: StudyResult) -> float:
    """A's mean first-attempt pick rate, as the levels use it."""
    return round(next(arm for arm in result.picks.arms if arm.name == "A").first_attempt.mean, 4)


def curve_readings(curves: dict[str, list[PlanPoint]], a: float) -> list[LevelReach]:
    """Every plan's reading at LEVELS and at A's mean pick rate ``a`` (level by level)."""
    return [reach(plan, points, level) for level in sorted({*LEVELS, a}) for plan, points in curves.items()]


def reach(plan: str, points: list[PlanPoint], level: float) -> LevelReach:
    """``plan``'s reading at ``level`` from its ``points`` (fewest labels first)."""
    hit = next((p for p in points if p.picks.mean >= level), None)
    possibly = next((p.labels for p in points if p.picks.interval[1] >= level), None)
    surely = next((p.labels for p in points if p.picks.interval[0] >= level), None)
    best = max(points, key=lambda p: (p.picks.mean, -p.labels))
    return LevelReach(plan, level, hit and hit.arm, hit and hit.labels, hit and hit.core_seconds, possibly, surely,
                      best, points[-1].labels)


def level_readings(result: StudyResult) -> list[LevelReach]:
    curves = plan_curves(result)
    return curve_readings(curves, a_rate(result)) if curves else []


def cell(r: LevelReach) -> str:
    if r.labels is None:
        return f"not reached (best {pct(r.best.picks.mean)}, {r.best.arm} at {r.best.labels:,})"
    surely = f"{r.surely:,}" if r.surely is not None else f"more than {r.largest:,}"
    span = f"{r.possibly:,}" if r.possibly == r.surely else f"{r.possibly:,} to {surely}"
    return f"{r.labels:,} labels, {r.core_seconds:.0f} core-s ({r.arm}; {span})"


def levels_lines(result: StudyResult) -> list[str]:
    """The table of the first lines: one row per level, one column per plan."""
    readings = level_readings(result)
    return levels_table(readings, a_rate(result)) if readings else []


def levels_table(readings: list[LevelReach], a: float) -> list[str]:
    """``readings`` as a table: one row per level (``a``: A's own), one column per plan."""
    plans = list(dict.fromkeys(r.plan for r in readings))
    rows = {}
    for r in readings:
        rows.setdefault(r.level, {})[r.plan] = cell(r)
    return ["", "**Labels to reach a pick level** (first attempt, held-out views): each plan's fewest labels whose "
            "mean picks reach the level, its core-seconds, and the range its intervals allow (from the fewest labels "
            "whose interval reaches the level to the fewest whose interval lies above it). A plan other than random "
            "labels is measured at its one size.", "",
            "| pick level | " + " | ".join(plans) + " |", "| --- |" + " --- |" * len(plans),
            *(f"| {pct(level)}{' (A)' if level == a else ''} | " + " | ".join(row.get(p, "-") for p in plans) + " |"
              for level, row in rows.items()), ""]
