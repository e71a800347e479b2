"""The page of a study on pick labels (docs/studies/pick_labels/study.md), rendered from its study.json
(study.pick_study.result): the answer first (A's picks against the target, the labels each plan needs to reach each pick
level, the measured ceiling), then the arms, the sets and how it was made."""

from __future__ import annotations

from pathlib import Path

from onepiece_dist.study.levels import RANDOM_PLAN, PlanPoint, curve_readings, levels_table
from onepiece_dist.study.markdown import in_words, pct, table
from onepiece_dist.study.pick_study.result import PickStudyResult, StudyArm
from onepiece_dist.study.result import Measure

A_TARGET = 0.80  # issue 58: the committed study at a size where A picks at least this at the first attempt
VERSUS = {"beats": "beats", "ties": "ties with", "loses": "loses to"}


def measure_text(m: Measure) -> str:
    return f"{pct(m.mean)} [{pct(m.interval[0])}, {pct(m.interval[1])}]"


def curves(result: PickStudyResult, set_name: str) -> dict[str, list[PlanPoint]]:
    """{plan: its points on ``set_name``}: A and R on one curve of label counts, each B at its one size."""
    found: dict[str, list[PlanPoint]] = {}
    for arm in result.arms:
        plan = RANDOM_PLAN if arm.kind in ("A", "R") else arm.name
        found.setdefault(plan, []).append(PlanPoint(arm.name, arm.labels, arm.label_core_seconds,
                                                    arm.picks[set_name].first_attempt))
    return {plan: sorted(points, key=lambda p: (p.labels, p.core_seconds)) for plan, points in found.items()}


def answer_lines(result: PickStudyResult) -> list[str]:
    first = result.sets[0]
    a = result.arm("A")
    a_picks = a.picks[first.name].first_attempt
    met = "met" if a_picks.mean >= A_TARGET else "**not met**"
    lines = [f"**Judged by picks.** From one depth view of each of {first.objects} {first.name} objects "
             f"({first.views} views; {first.what}), A's networks ({a.labels:,} pick labels, {len(a.checkpoints)} "
             f"seeds) pick {measure_text(a_picks)} at the first attempt; a random candidate picks "
             f"{measure_text(first.random)}"
             f"{'' if first.separable else ' (too near 0 or 1 to tell a network from a guess)'}. "
             f"A at or above {pct(A_TARGET)}: {met}."]
    inside = [arm for arm in result.arms if arm.picks[first.name].first_attempt.mean >= a_picks.interval[0]]
    cheapest = min(inside, key=lambda arm: arm.label_core_seconds)
    lines.append(f"The cheapest plan inside A's interval by picks is **{cheapest.name}**: "
                 f"{pct(cheapest.picks[first.name].first_attempt.mean)} from {cheapest.labels:,} labels, "
                 f"{cheapest.label_core_seconds:,.0f} core-seconds of labelling against A's {a.label_core_seconds:,.0f}"
                 f" ({a.label_core_seconds / max(cheapest.label_core_seconds, 1e-9):.1f}x less).")
    lines += [f"By picks on the {first.name} views, {name} {VERSUS[verdict]} random labels of its size (R ~{name}; "
              f"the {result.confidence:.0%} interval of their per-object difference)."
              for name, verdict in result.b_versus_random[first.name].items()]
    return lines + levels_table(curve_readings(curves(result, first.name), round(a_picks.mean, 4)), a_picks.mean)


def ceiling_lines(result: PickStudyResult) -> list[str]:
    c = result.ceiling
    if c is None:
        return []
    span = c.ap - c.positive_rate
    share = {arm.name: (arm.ap_ensemble - c.positive_rate) / span for arm in result.arms
             if arm.ap_ensemble is not None and span > 0}
    a = result.arm("A")
    return [f"**The ceiling, measured.** {c.grasps} {c.set} candidates ({c.grasps // max(result.sets[0].views, 1)} "
            f"per view, seeded), each executed {c.draws} times by the pick protocol (the label every arm learns): "
            f"two executions of one grasp agree {pct(c.agreement)}; against one execution the floor (positive rate) "
            f"is {c.positive_rate:.3f} and the best AP a predictor could reach **{c.ap:.3f} [{c.low:.3f}, "
            f"{c.high:.3f}]** (the odds' distribution the counts make most likely; 95% interval, candidates "
            f"resampled). Two moments alone allow {c.moment_range[0]:.3f} to {c.moment_range[1]:.3f}.",
            "",
            f"On the same executions A's networks reach AP {a.ap_single:.3f} one at a time (the mean of each seed's "
            f"own) and {a.ap_ensemble:.3f} as an ensemble (the seeds' mean score): **{share.get('A', 0):.0%} of the "
            f"way from the floor to the ceiling**; "
            + in_words([f"{name} {value:.0%}" for name, value in share.items() if name != "A"]) + " (ensembles)."]


def arms_lines(result: PickStudyResult) -> list[str]:
    sets = [s.name for s in result.sets]
    a_low = result.arm("A").picks[sets[0]].first_attempt.interval[0]
    header = ["arm", "labels", "label core-s", "fit s (mean)",
              *[f"{name} first attempt [{result.confidence:.0%} CI]" for name in sets],
              f"{sets[0]} per seed", "AP (single)", "AP (ensemble)", f"inside A ({sets[0]})"]
    return table(header, [_arm_row(arm, sets, a_low) for arm in result.arms])


def _arm_row(arm: StudyArm, sets: list[str], a_low: float) -> list:
    first = arm.picks[sets[0]]
    return [arm.name, f"{arm.labels:,}", f"{arm.label_core_seconds:,.0f}",
            f"{sum(arm.fit_seconds) / len(arm.fit_seconds):,.0f}",
            *[measure_text(arm.picks[name].first_attempt) for name in sets],
            " / ".join(pct(x) for x in first.per_seed), _ap(arm.ap_single), _ap(arm.ap_ensemble),
            "yes" if first.first_attempt.mean >= a_low else "no"]


def _ap(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def sets_lines(result: PickStudyResult) -> list[str]:
    lines = []
    for s in result.sets[1:]:
        a = result.arm("A").picks[s.name].first_attempt
        verdicts = ", ".join(f"{name} {VERSUS[v]} R ~{name}" for name, v in result.b_versus_random[s.name].items())
        lines.append(f"On the {s.name} set ({s.objects} objects, {s.views} views; {s.what}) A picks "
                     f"{measure_text(a)}, a random candidate {measure_text(s.random)}; {verdicts}.")
    return lines


def page_text(result: PickStudyResult) -> str:
    labels = result.labels
    design = ", ".join(f"{k} {v}" for k, v in result.design.items() if v is not None and k != "name")
    lines = ["# Study on pick labels: the labels each plan needs to reach a network that picks", "",
             *answer_lines(result), *ceiling_lines(result), "", "## Arms", "",
             f"A labels every candidate; R a seeded random share (R ~B r: as many as B r); B r one grasp per voxel "
             f"shape (the crops' occupancy on the network's grid, codes within Hamming radius r merged; the pick "
             f"protocol lifts an object off a table, so B labels each unique shape once where the camera saw it, "
             f"not an assembled one object). Every arm fits design `{result.design['name']}` ({design}), one "
             f"network per seed; label core-seconds: the labelling's mean per label times the arm's labels (B: "
             f"plus its dedup).", "", *arms_lines(result), "", "## Held-out sets", "", *sets_lines(result), "",
             "## The labels", "",
             f"{labels.rows:,} candidates on {labels.objects} training objects ({in_words(list(labels.sources))}), "
             f"8 views each, 16 of each view's candidates executed by the pick protocol (success rate "
             f"{pct(labels.success_rate)}), {labels.core_seconds:,.0f} core-seconds "
             f"({1000 * labels.per_label():.0f} core-ms per label).", "",
             f"Made by `{result.command}` ({result.date}, {result.machine}).", ""]
    return "\n".join(lines)


def read_result(folder: Path) -> PickStudyResult:
    return PickStudyResult.model_validate_json((folder / "study.json").read_text())


def write_page(folder: Path) -> None:
    (folder / "study.md").write_text(page_text(read_result(folder)))
