"""How a job spends labels beyond extraction: a budget of candidates labelled on their own objects, adaptive rounds
the network chooses, and the held-out evaluation (JobSpec's budget, adaptive and evaluate)."""

from __future__ import annotations

import math

from pydantic import Field, field_validator, model_validator

from onepiece_dist.specs.frozen import Frozen


class BudgetSpec(Frozen):
    """Label only a seeded subset of the extracted candidates, on their own objects, spread over every object:
    the R plan of a study as a job (job/stages/label_budget.py). Give a count or a fraction, not both; neither labels as
    the stages say (every candidate with sim.label, or the one object)."""

    count: int | None = Field(None, ge=1, description="Candidates to label in all (at least one per object; more "
                              "than there are labels them all).")
    fraction: float | None = Field(None, description="Share of the extracted candidates to label, in (0, 1].")

    @field_validator("fraction")
    @classmethod
    def _share(cls, fraction: float | None) -> float | None:
        if fraction is not None and not 0 < fraction <= 1:
            raise ValueError(f"{fraction}: a share of the candidates in (0, 1]")
        return fraction

    @model_validator(mode="after")
    def _one_of(self) -> BudgetSpec:
        if self.count is not None and self.fraction is not None:
            raise ValueError("budget: give a count or a fraction, not both")
        return self

    @property
    def enabled(self) -> bool:
        return self.count is not None or self.fraction is not None

    def size(self, candidates: int) -> int:
        """How many of ``candidates`` the budget labels."""
        if self.count is not None:
            return min(self.count, candidates)
        return min(candidates, max(1, math.ceil((self.fraction or 0) * candidates - 1e-9)))


class RoundsRule(Frozen):
    """Labels chosen by a network in rounds: round 0 takes one candidate per voxel code, each later round those it
    is least sure of; the rounds stop when the validation AP has not risen by more than ``margin`` for
    ``patience`` rounds, or after ``rounds`` rounds. Shares are of the candidates."""

    first: float = Field(0.02, gt=0, le=1, description="Round 0: this share of the candidates, one per voxel code.")
    batch: float = Field(0.01, gt=0, le=1, description="Each later round: this share, where the network is least "
                         "sure, one per code while codes last.")
    rounds: int = Field(6, ge=0, le=100, description="Rounds after the first, at most.")
    patience: int = Field(2, ge=1, le=100, description="Stop after this many rounds without a validation AP gain "
                          "above margin.")
    margin: float = Field(0.005, ge=0, le=1, description="The validation AP gain that counts as a rise.")

    def count(self, share: float, candidates: int) -> int:
        """Candidates for ``share`` of ``candidates``: at least one."""
        return max(1, min(candidates, round(share * candidates)))

    def stale(self, validation_aps: list[float]) -> int:
        """Rounds since the validation AP last rose by more than ``margin`` over its best before."""
        best, stale = -math.inf, 0
        for ap in validation_aps:
            best, stale = (ap, 0) if ap > best + self.margin else (best, stale + 1)
        return stale


class AdaptiveSpec(RoundsRule):
    """Adaptive labelling (job/stages/label_rounds.py): the label stage in rounds. Every candidate is extracted; round
    0 labels one candidate per voxel code (codes in a seeded order) and a fixed validation set on validation
    objects held out from the rounds; after each round the trainer trains (warm start from the last round) and
    scores every candidate; the next round labels those it is least sure of. The rounds also stop at ``limit``."""

    enabled: bool = Field(False, description="Label in rounds chosen by the network (needs stages 'label' and "
                          "'train', no 'assemble', sim.label false).")
    limit: float = Field(0.1, gt=0, le=1, description="The label budget: stop before the labels exceed this share "
                         "of the candidates.")
    validation: float = Field(0.2, gt=0, lt=1, description="Share of the objects held out from the rounds; their "
                              "validation_grasps labels measure each round's AP.")
    validation_grasps: int = Field(16, ge=1, le=100_000, description="Candidates labelled on each validation "
                                   "object in round 0 (at most its candidates).")
    steps: int = Field(300, ge=1, le=1_000_000, description="Gradient steps of each round's training.")


class EvaluateSpec(Frozen):
    """The evaluate stage: the trained network on objects it never saw, every candidate labelled by the same
    protocol through the worker pool (a job of its own, ``<output>.eval.zarr``)."""

    objects: str = Field("pybullet:random_urdfs[500:504]", description="Held-out objects (a source as in "
                         "'objects'); none should be a train object.")
    grasps_per_object: int = Field(32, ge=1, le=100_000, description="Candidates sampled and labelled per held-out "
                                   "object.")
    label_trials: int = Field(4, ge=1, le=32, description="K: label trials per held-out candidate; a candidate is a "
                              "success when every one of the K held (the robust rule, sim.success: every_trial), so "
                              "the held-out labels separate good grasps from lucky ones.")
