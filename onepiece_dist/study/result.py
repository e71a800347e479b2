"""What a study found, typed and frozen: each arm's cost and held-out score, the premise figures and the decision.
``study.json`` is a :class:`StudyResult` (its JSON Schema: schemas/study_result.schema.json); the page is rendered
from it and nothing else.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from onepiece_dist.specs.frozen import Frozen
from onepiece_dist.study.spec import StudySpec

FORMAT = 1  # bump when a field changes meaning


class Measure(Frozen):
    """A held-out measure over training seeds: its mean, its spread and its interval over held-out objects."""

    mean: float
    std: float = Field(description="Standard deviation over training seeds.")
    interval: tuple[float, float] = Field(description="Bootstrap interval over held-out objects at the study's "
                                          "confidence (top-1: seed-averaged per-object success; AP: seed-averaged "
                                          "scores).")


class SeedRun(Frozen):
    """One training run of an arm."""

    seed: int
    top1: float
    top5: float
    ap: float
    accuracy: float
    best_step: int
    train_seconds: float
    train_grasps: int


class HeldoutScore(Frozen):
    """An arm's network on the held-out objects: the success of each object's top-ranked grasp, the mean of its 5
    best, AP over every held-out grasp, accuracy at one half."""

    top1: Measure
    top5: Measure
    ap: Measure
    accuracy: Measure
    learning_rate: float = Field(description="The rate its own validation split picked.")
    seeds: list[SeedRun]


class ArmCost(Frozen):
    """What an arm's labelled data cost to make. Core-seconds are summed inside the workers (and the central
    actor's stages), so they do not depend on how many workers ran."""

    core_seconds: float = Field(description="Extraction, dedup, assembly and labelling, in core-seconds.")
    stages: dict[str, float] = Field(description="Core-seconds per stage.")
    label_trials: int = Field(description="Physics trials spent on labels.")
    labelled_grasps: int
    labelled_bytes: int = Field(description="Bytes on disk of the labelled grasps the network trains on.")
    dataset_bytes: int = Field(description="Bytes on disk of the arm's whole dataset (shared for R: its share).")
    delivered_bytes: int = Field(description="Bytes of what a trainer needs (store.dataset.delivered_groups): B's "
                                 "one object and labels, A's labelled grasps (R: its share of A's).")


class ArmRound(Frozen):
    """One round of the adaptive arm: its labels so far and the validation AP of the network trained on them."""

    round: int
    labels: int
    validation_ap: float


class Arm(Frozen):
    """One arm: A (every candidate labelled on its own object), B (the one object at a similar-shape radius) or R
    (a random subset of A's labels, of a budget's size or of a B arm's size)."""

    name: str = Field(description="'A', 'B r<radius>', 'B static r<radius>', 'R <share>', 'R ~<B arm>', 'U' or "
                      "'R ~U'.")
    kind: Literal["A", "B", "R", "U"]
    radius: int | None = Field(None, description="B: the similar-shape radius; R ~B: the matched B arm's.")
    share: float | None = Field(None, description="R: share of A's labelled candidates.")
    unique_codes: int | None = Field(None, description="B: patches on the one object.")
    cost: ArmCost
    heldout: HeldoutScore
    time_ratio: float = Field(description="A's core-seconds over this arm's.")
    storage_ratio: float = Field(description="A's labelled bytes over this arm's.")
    within_a: bool = Field(description="Mean top-1 and mean AP both inside A's intervals or above them.")


class Baselines(Frozen):
    """The held-out set and what needs no network: a random choice per object and an oracle."""

    objects: int
    grasps: int
    positive_rate: float
    random_choice: float = Field(description="Expected top-1 of a random candidate per object.")
    oracle: float = Field(description="Top-1 of an oracle (1 where the object has any good candidate).")


class Premise(Frozen):
    """How far a label computed once for a shape holds for the other grasps that share its code (B r<radius>
    against A's labels of the same candidates), and how much the code decides the label."""

    radius: int
    matched_grasps: int = Field(description="B's extracted grasps found among A's (same object and candidate).")
    patch_vs_representative: float | None = Field(description="The patch's label on the one object agrees with "
                                                  "its representative's label on its own object.")
    patch_vs_every_grasp: float | None = Field(description="The patch's label agrees with every grasp it stands "
                                               "for.")
    shuffled_patches: float | None = Field(description="The same with patch labels shuffled: the floor.")
    same_code: float | None = Field(description="A's labels of two grasps sharing a code agree.")
    random_pairs: float | None = Field(description="A's labels of two random grasps with different codes agree.")
    share_decided: float | None = Field(description="(same_code - random_pairs) / (1 - random_pairs): how much of "
                                        "the label's headroom over chance the code decides.")


class LabelFit(Frozen):
    """With a force-closure study: how well the train label itself, with no network, predicts the held-out truth
    (physics trials) on the held-out candidates, which carry both."""

    label: str = Field(description="The train arms' label ('force_closure').")
    good_mu: float
    grasps: int = Field(description="Held-out candidates scored.")
    closure_positive_rate: float = Field(description="Share good by force closure (fc_mu <= good_mu).")
    physics_positive_rate: float = Field(description="Share that held in the physics trials (the truth).")
    agreement: float = Field(description="Force-closure label equal to the physics label.")
    ap: float = Field(description="AP of ranking the candidates by fc_mu (lowest first, ties counted together) "
                      "for physics success.")
    top1: float = Field(description="Per object, the expected physics success of a candidate drawn among those "
                        "with the lowest fc_mu; mean over objects.")


class LookupRanking(Frozen):
    """Held-out grasps ranked by the mean train label of their code among ``labels`` train labels."""

    labels: int
    coverage: float = Field(description="Held-out grasps whose code is among the labelled train grasps'.")
    ap: float = Field(description="AP over the held-out grasps (ties counted together).")
    accuracy: float = Field(description="Accuracy of a score above one half.")


class KeyLookup(Frozen):
    """The premise with perfect patches and no network (study.lookup): each held-out grasp looks its code up
    among A's train grasps and takes one train label of that code (B's one label per code) or the code's
    majority; and held-out grasps ranked by such lookups from every train label (A), one label per code (B), as
    many random labels (R) or labels spread over the codes by count (S), B, R and S over seeded draws."""

    train_codes: int = Field(description="Distinct codes among A's grasps.")
    coverage: float = Field(description="Held-out grasps whose code some train grasp has.")
    one_label: float | None = Field(description="Agreement of one train label of the code with the held-out label.")
    one_label_floor: float | None = Field(description="The same for labels that ignore the shape.")
    majority: float | None = Field(description="Agreement of the code's majority train label.")
    majority_floor: float | None
    ranked: dict[str, LookupRanking] = Field(description="'A', 'B', 'R', 'S'.")


class Decision(Frozen):
    """The answer, first lines of the page: the cheapest plan as good as A, and whether the one object pays."""

    cheapest: str | None = Field(description="The arm with the lowest core-seconds whose top-1 and AP lie within "
                                 "A's intervals (A itself when no other does).")
    cheapest_core_seconds: float | None
    cheapest_label_trials: int | None
    cheapest_labelled_bytes: int | None
    cheapest_time_ratio: float | None
    cheapest_storage_ratio: float | None
    time_met: bool = Field(description="The cheapest plan's time ratio reaches targets.time_ratio.")
    storage_met: bool = Field(description="Its storage ratio reaches targets.storage_ratio.")
    best_b: str | None = Field(description="The cheapest B arm within A's intervals, if any.")
    b_beats_random: dict[str, bool] = Field(description="Per B arm: its top-1 and AP are both at least those of "
                                            "the R arm of its size.")
    u_beats_random: bool | None = Field(None, description="The adaptive arm's top-1 and AP both at least those of "
                                        "R ~U, random labels of its size (with spec.adaptive).")
    u_cost_share: float | None = Field(None, description="U's core-seconds over A's.")
    u_met: bool | None = Field(None, description="U inside A's intervals at no more than targets.adaptive_share of "
                               "A's core-seconds.")
    r_labels_at_u_ap: int | None = Field(None, description="The fewest labels of an R arm whose mean held-out AP "
                                         "reaches U's (None: no R arm does).")


class KeyMeasure(Frozen):
    """One key of spec.keys (study.keys): how many distinct keys A's grasps have and the key as a lookup."""

    name: str
    key_bytes: int
    unique: int = Field(description="Distinct keys among A's grasps.")
    unique_fraction: float = Field(description="unique over A's grasps: the labels one label per key pays for.")
    lookup: KeyLookup


class Ceiling(Frozen):
    """The label's own ceiling on a seeded sample of held-out candidates (stats.ceiling), each labelled again by
    fresh executions: draws per grasp, their positive rate (the floor: a constant predictor's AP), the chance two
    executions of one grasp agree, the best AP against one execution as the draws alone show it (leave one out: a
    lower bound with few draws) and with the odds' spread fitted to the draws (the ceiling); and each arm's
    networks (seed-averaged scores) against the same executions."""

    grasps: int
    draws: int
    positive_rate: float
    agreement: float
    ceiling_ap: float = Field(description="Leave-one-out: at least this.")
    fitted_ap: float = Field(description="The ceiling: ranking by the odds, their spread fitted to the draws.")
    arm_ap: dict[str, float] = Field(default_factory=dict, description="Each arm's AP against the executions, its "
                                     "seeds' scores averaged (an ensemble of its networks).")
    single_ap: dict[str, float] = Field(default_factory=dict, description="Each arm's single networks: the mean "
                                        "over its seeds of each network's own AP against the executions.")
    measured_ap: float | None = Field(None, description="With 8 draws or more: the ceiling measured (the odds' "
                                      "distribution the draws' counts make most likely; stats.measured_ceiling).")
    measured_interval: tuple[float, float] | None = Field(None, description="Its 95% interval (grasps resampled).")
    moment_range: tuple[float, float] | None = Field(None, description="The AP range of the two-point odds that "
                                                     "match the draws' two moments (the fit's cross-check).")

    @property
    def ceiling(self) -> float:
        """The ceiling the arms are placed against: the measured one where there is one, else the fitted one."""
        return self.fitted_ap if self.measured_ap is None else self.measured_ap

    def share_of_way(self, ap: float) -> float | None:
        """Where ``ap`` stands from the floor (0) to the ceiling (1); None when the ceiling is the floor."""
        span = self.ceiling - self.positive_rate
        return None if span <= 1e-12 else (ap - self.positive_rate) / span


class ArmPicks(Frozen):
    """An arm judged by picks: each seed's network's first choice per view, the per-object share picked (over
    views and seeds), its mean over objects with a bootstrap interval over objects."""

    name: str
    first_attempt: Measure
    within_a: bool = Field(description="Its mean lies inside A's interval.")


class PicksJudgement(Frozen):
    """The arms judged by pick success from one depth view (spec.judge: picks or both)."""

    objects: int
    views: int
    label: str = Field(description="The protocol each pick is executed with.")
    random: Measure = Field(description="A random collision-free candidate per view (the guess).")
    separable: bool = Field(description="Whether the guess's rate leaves room to rank (10% to 90%).")
    arms: list[ArmPicks]
    cheapest: str | None = Field(description="The cheapest arm (core-seconds) inside A's interval.")
    b_beats_random: dict[str, bool] = Field(description="B r against R ~B r: it beats R (see b_versus_random).")
    b_versus_random: dict[str, str] = Field(default_factory=dict, description="B r against R ~B r by the 95% "
                                            "interval of their per-object difference: beats, ties or loses.")


class StudyResult(Frozen):
    """A study's result: ``study.json``."""

    format: int = FORMAT
    spec: StudySpec
    digest: str = Field(description="The spec's digest: names the study.")
    date: str
    machine: str
    package_version: str
    wall_seconds: float = Field(description="The study's wall time (reused jobs and runs cost none).")
    reused_jobs: list[str]
    reused_runs: int
    train_objects: int = Field(description="Train objects accepted (rejected ones are listed).")
    rejected: list[str] = Field(description="'name: reason' of every object a job rejected.")
    heldout: Baselines
    arms: list[Arm]
    premise: list[Premise]
    adaptive: list[ArmRound] | None = Field(None, description="The adaptive arm's rounds (with "
                                                 "spec.adaptive).")
    lookup: KeyLookup | None = Field(None, description="The code as a lookup, without a network.")
    keys: list[KeyMeasure] = Field([], description="The other keys of spec.keys as lookups.")
    label_fit: LabelFit | None = Field(None, description="The train label against the held-out truth (force-closure "
                                       "studies).")
    decision: Decision
    ceiling: Ceiling | None = Field(None, description="The label's own ceiling (spec.ceiling_grasps > 0).")
    picks: PicksJudgement | None = Field(None, description="The arms judged by picks (spec.judge: picks, both).")
