"""The pick label drawn again (issue 58: the ceiling measured, not fitted): on each view of each held-out object,
seen exactly as the pick benchmark sees it (picks.views), a seeded sample of the planner's candidates, each
executed many times by the pick protocol, and each network's score of it.

Draw 0 is the candidate's own execution (the generator every chooser meets, picks.views.Executions.run); draw d > 0
is Executions.again's, from a generator of its own, so draws do not depend on the sample, its order or how many
draws were asked.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.picks.networks import scored_world
from onepiece_dist.picks.object_picks import process_scorer
from onepiece_dist.picks.runner import run_each_in_process
from onepiece_dist.picks.views import Executions, observe_view, ranked_indices, simulated_object
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PickSpec

SAMPLE = 5858  # the stream of each view's sampled candidates


@dataclass(frozen=True)
class CandidateDraws:
    """One object's sampled candidates: per candidate its ``view`` and ``candidate`` index among the view's
    proposals, its ``draws`` (each a fresh execution: picked or not) and each network's ``scores``; ``status``
    'ok' or 'rejected' with ``reason``."""

    index: int
    name: str
    status: str
    views: tuple[int, ...] = ()
    candidates: tuple[int, ...] = ()
    draws: tuple[tuple[bool, ...], ...] = ()
    scores: tuple[tuple[float, ...], ...] = ()
    reason: str = ""
    seconds: float = 0.0


def draw_candidates(spec: PickSpec, ref: ObjectRef, index: int, checkpoints: tuple[str, ...], per_view: int,
                    draws: int) -> CandidateDraws:
    """Every view of one object: ``per_view`` seeded candidates, each executed ``draws`` times and scored by
    every network (a bad object: a rejected result)."""
    start = time.perf_counter()
    try:
        scorers, world, loaded = scored_world(spec, checkpoints, ref)
    except MeshRejected as err:
        return CandidateDraws(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    rows = [row for view in spec.view_indices for row in _view(spec, scorers, world, loaded.mesh, view, per_view,
                                                               draws)]
    return CandidateDraws(index, ref.name, "ok", tuple(r[0] for r in rows), tuple(r[1] for r in rows),
                          tuple(r[2] for r in rows), tuple(r[3] for r in rows), seconds=time.perf_counter() - start)


def _view(spec: PickSpec, scorers: list[GraspScorer], world, mesh, view: int, per_view: int, draws: int) -> list:
    seen = observe_view(spec, scorers[0].record, world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return []
    count = len(proposals.poses)
    chosen = np.sort(np.random.default_rng([int(mesh.content_id[:16], 16), spec.seed, view, SAMPLE])
                     .permutation(count)[:per_view])
    scores = np.stack([scorer.score(proposals.crops, spec.plan.batch_size) for scorer in scorers], axis=1)
    executions = Executions(spec, world, mesh, seen.resting, view)
    rows = []
    for candidate in (int(c) for c in chosen):
        outcomes = executions.picked("view", candidate, proposals.poses[candidate], draws)
        rows.append((view, candidate, outcomes, tuple(float(s) for s in scores[candidate])))
    return rows


@dataclass(frozen=True)
class RankedDraws:
    """One view's ``top`` best-ranked candidates by the network (the planner's ranking, best first): each one's
    ``score`` and its ``draws`` (draw 0 the execution every chooser meets, then fresh ones); ``top_down`` whether it
    is one of the view's top-down grasps."""

    view: int
    scores: tuple[float, ...]
    draws: tuple[tuple[bool, ...], ...]
    top_down: tuple[bool, ...]


def ranked_draws(spec: PickSpec, ref: ObjectRef, index: int, top: int, draws: int) -> tuple[int, str, tuple, str]:
    """Every view of one object (index, name, its RankedDraws, a rejected object's reason): how often the grasps
    ``spec.checkpoint`` ranks first pick again, and whether a surer one sits just under its first."""
    scorer = process_scorer(spec)
    try:
        world, loaded = simulated_object(spec, scorer.record, ref)
    except MeshRejected as err:
        return index, ref.name, (), err.reason
    views = []
    for view in spec.view_indices:
        seen = observe_view(spec, scorer.record, world, loaded.mesh, view)
        proposals = seen.proposals
        if proposals is None:
            continue
        ranked, chosen = ranked_indices(proposals, scorer.score(proposals.crops, spec.plan.batch_size),
                                        scorer.record, spec.plan, top)
        executions = Executions(spec, world, loaded.mesh, seen.resting, view)
        outcomes = [executions.picked("view", i, proposals.poses[i], draws) for i in chosen]
        views.append(RankedDraws(view, tuple(g.score for g in ranked), tuple(outcomes),
                                 tuple(i >= len(proposals.poses) - proposals.top_down for i in chosen)))
    return index, ref.name, tuple(views), ""


def run_candidate_draws(spec: PickSpec, checkpoints: tuple[str, ...], per_view: int, draws: int
                        ) -> list[CandidateDraws]:
    """Every object of ``spec.objects``, one at a time in a pinned simulation process (picks.runner)."""
    Path(spec.output).mkdir(parents=True, exist_ok=True)
    task = functools.partial(draw_candidates, checkpoints=checkpoints, per_view=per_view, draws=draws)
    return run_each_in_process(task, spec, resolve_source(spec.objects))


@dataclass(frozen=True)
class ViewCeiling:
    """One view's pool against fresh draws: its ``candidates``; whether one picked at draw 0 (the draw every chooser
    meets: the benchmark's oracle); how many picked at each screening draw 0 .. screen - 1; the share of ``judge``
    fresh draws from draw ``screen`` at which the first of those (index order) picked; and the share of ``judge``
    draws from draw ``selection``, which no choice saw, at which the best of the first ``shortlist`` of them picked
    (the first that held at every draw screen .. selection - 1, else the one that held longest). None where none
    passed the screen."""

    view: int
    candidates: int
    one_draw: bool
    repeated: int
    first_held_out: float | None
    best_held_out: float | None


@dataclass(frozen=True)
class CeilingDraws:
    """How a view's candidates are drawn: ``screen`` draws every kept candidate must pick at (draw 0 the oracle's);
    of those that did, the first ``shortlist`` (index order) drawn until they fail, up to draw ``selection`` - 1;
    each chosen one judged at ``judge`` draws it was not chosen by."""

    screen: int = 4
    selection: int = 12
    shortlist: int = 8
    judge: int = 4


def view_ceilings(spec: PickSpec, ref: ObjectRef, index: int, draws: CeilingDraws
                  ) -> tuple[int, str, tuple, str]:
    """Every view of one object (index, name, its ViewCeilings, a rejected object's reason): what a chooser that
    knew which candidates pick again reaches, measured rather than read off one draw: the oracle picks whatever
    won its one draw, and two executions of one grasp agree only about 90% of the time."""
    record = GraspScorer(shipped_network(spec.gripper), spec.gripper, device="cpu").record  # the planner's crops
    try:
        world, loaded = simulated_object(spec, record, ref)
    except MeshRejected as err:
        return index, ref.name, (), err.reason
    return index, ref.name, tuple(_ceiling(spec, record, world, loaded.mesh, view, draws)
                                  for view in spec.view_indices), ""


def _ceiling(spec: PickSpec, record, world, mesh, view: int, draws: CeilingDraws) -> ViewCeiling:
    seen = observe_view(spec, record, world, mesh, view)
    poses = seen.proposals.poses if seen.proposals is not None else np.zeros((0, 4, 4))
    poses = poses[: spec.oracle_candidates]
    executions = Executions(spec, world, mesh, seen.resting, view)
    kept = [i for i in range(len(poses)) if executions.run("view", i, poses[i]).success]
    one_draw = bool(kept)
    for draw in range(1, draws.screen):
        kept = [i for i in kept if executions.again("view", i, poses[i], draw).success]
    if not kept:
        return ViewCeiling(view, len(poses), one_draw, 0, None, None)
    held = {i: _held_until_failure(executions, i, poses[i], draws.screen, draws.selection)
            for i in kept[: draws.shortlist]}
    best = max(held, key=lambda i: (held[i], -i))
    first = executions.picked("view", kept[0], poses[kept[0]], draws.judge, draws.screen)
    return ViewCeiling(view, len(poses), one_draw, len(kept), float(np.mean(first)),
                       float(np.mean(executions.picked("view", best, poses[best], draws.judge, draws.selection))))


def _held_until_failure(executions: Executions, index: int, pose: np.ndarray, first: int, end: int) -> int:
    """How many draws from ``first`` (up to ``end`` - 1) candidate ``index`` picked at before its first failure."""
    for draw in range(first, end):
        if not executions.again("view", index, pose, draw).success:
            return draw - first
    return end - first
