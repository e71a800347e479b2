"""What a study on pick labels found (issue 58, docs/studies/pick_labels): typed records that the study writes as
study.json and the page reads back (study.pick_study.page), never a dict read by key."""

from __future__ import annotations

from pydantic import Field

from onepiece_dist.specs.frozen import Frozen
from onepiece_dist.study.result import Measure


class PickLabelsUsed(Frozen):
    """The pick labels every arm draws from."""

    rows: int
    objects: int
    success_rate: float
    core_seconds: float = Field(description="Core-seconds of the labelling, all rows.")
    sources: tuple[str, ...] = Field(description="The objects of each batch of labels.")

    def per_label(self) -> float:
        return self.core_seconds / max(self.rows, 1)


class SetPicks(Frozen):
    """An arm's networks on one set of held-out views: first-attempt picks (a Measure over objects and seeds), the
    per-object rates (seeds averaged; for paired comparisons) and each seed's own rate."""

    first_attempt: Measure
    per_object: tuple[float, ...]
    per_seed: tuple[float, ...]


class StudyArm(Frozen):
    """One plan at one size: A (every label), R (a seeded random share), B (one grasp per voxel shape at
    ``radius``)."""

    name: str
    kind: str
    radius: int | None = None
    labels: int
    label_core_seconds: float = Field(description="The labelling's core-seconds of its rows (the labels' mean "
                                      "per row), plus B's dedup.")
    fit_seconds: tuple[float, ...] = Field(description="Each seed's fit (one core-pair process).")
    checkpoints: tuple[str, ...]
    picks: dict[str, SetPicks] = Field(description="Per set of held-out views.")
    ap_single: float | None = Field(None, description="Mean over seeds of each network's AP against the "
                                    "ceiling's draws.")
    ap_ensemble: float | None = Field(None, description="AP of the seeds' mean score against the same draws.")


class HeldOutSet(Frozen):
    """A set of held-out views: what it is, whether designs were chosen on it, its objects and views, and a random
    candidate's first-attempt rate (can a network be told from a guess there)."""

    name: str
    what: str
    chosen_on: bool
    objects: int
    views: int
    random: Measure
    separable: bool


class MeasuredPickCeiling(Frozen):
    """The pick label's ceiling, measured: ``grasps`` held-out candidates (a seeded few per view of ``set``) each
    executed ``draws`` times; the best AP a predictor could reach against one execution with its interval, what two
    moments alone allow, two executions' agreement and the positive rate (the floor)."""

    set: str
    grasps: int
    draws: int
    positive_rate: float
    agreement: float
    ap: float
    low: float
    high: float
    moment_range: tuple[float, float]


class PickStudyResult(Frozen):
    """The study: its labels, design, held-out sets (the first decides), arms, B against random labels of its
    size per set, and the measured ceiling."""

    command: str
    date: str
    machine: str
    design: dict
    labels: PickLabelsUsed
    sets: tuple[HeldOutSet, ...]
    arms: tuple[StudyArm, ...]
    b_versus_random: dict[str, dict[str, str]] = Field(description="{set: {B arm: beats / ties / loses}}")
    ceiling: MeasuredPickCeiling | None = None
    confidence: float = 0.95

    def arm(self, name: str) -> StudyArm:
        return next(a for a in self.arms if a.name == name)
