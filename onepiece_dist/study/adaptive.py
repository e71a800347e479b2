"""The adaptive arm (U): labels chosen by the network, in rounds, from A's candidates (issue 39).

The study has A's label for every train candidate, so it can play a labelling plan without labelling anything
again: a plan's labels are A's labels of the candidates it picks, charged A's cost per candidate (as R is). U
picks in rounds. Round 0 takes one candidate per voxel code (the codes give diversity, as ONE PIECE's dedup
intends), at random among the codes, up to ``adaptive.first`` of A's candidates. After each round a network trains
on what U holds (A's learning rate, seed 0; the checkpoint its own validation split picks, whole objects of the
labelled rows held back) and scores every candidate; the next round takes the ``adaptive.batch`` unlabelled
candidates it is least sure of (score nearest one half), at most one per code while codes last. U stops when the
round's validation AP has not risen by more than ``adaptive.margin`` for ``adaptive.patience`` rounds, after
``adaptive.rounds`` rounds, or when every candidate is labelled. Its labelled rows then train like every other
arm and are scored on the held-out objects.

The validation rows are part of U's labels, so they grow with it: a round's figure is measured on more objects'
labels than the round before. Round runs are kept in the study's run store: a study run again picks the same rows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.learn.train import StepResult, StepRun
from onepiece_dist.stats.selection import first_rows, least_sure
from onepiece_dist.store import open_dataset
from onepiece_dist.study.result import ArmRound
from onepiece_dist.study.spec import StudySpec

TrainOne = Callable[[StepRun], StepResult]






def validation_ap(result: StepResult) -> float:
    """The validation AP at the checkpoint the run kept."""
    return float(result.best_point().validation.ap)


def adaptive_rows(spec: StudySpec, a_output: str, learning_rate: float, train_one: TrainOne
                  ) -> tuple[tuple[int, ...], list[ArmRound]]:
    """U's labelled rows of A and its rounds."""
    plan, t = spec.adaptive, spec.training
    inverse = unique_codes(open_dataset(a_output)["grasps/code"]).inverse
    n = len(inverse)
    share = lambda fraction: max(2, min(n, round(fraction * n)))  # noqa: E731 - a count of A's candidates
    labelled = first_rows(inverse, share(plan.first), np.random.default_rng([spec.seed, 41]))
    base = StepRun(a_output, "grasps", None, a_output, t.model, t.steps, t.batch_size, learning_rate, t.validation,
                   0, t.evaluations, device=t.device)
    rounds: list[ArmRound] = []
    aps: list[float] = []
    for number in range(plan.rounds + 1):
        result = train_one(dataclasses.replace(base, rows=tuple(int(r) for r in np.sort(labelled))))
        aps.append(validation_ap(result))
        rounds.append(ArmRound(round=number, labels=int(len(labelled)), validation_ap=round(aps[-1], 4)))
        if plan.stale(aps) >= plan.patience or number == plan.rounds or len(labelled) >= n:
            break
        labelled = np.concatenate([labelled, least_sure(result.scores, labelled, inverse, share(plan.batch))])
    return tuple(int(r) for r in np.sort(labelled)), rounds
