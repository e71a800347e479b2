"""Clearing the table (VGN's declutter protocol; docs/picks.md): a scene of several objects (picks.clutter)
settled once; then, round after round, a new seeded camera sees what is left, the chooser's first grasp is
executed by the pick protocol on the object it closes on, and a picked object leaves the table. It ends when the
table is clear, after MAX_FAILURES failed rounds in a row, or after MAX_ROUNDS rounds per object.

Laid apart, what is left stays where it rested: a pick does not push its neighbours, and a failed pick leaves the
scene as it was (each trial of the protocol starts from rest). In a pile (``PickSpec.pile``) what is left settles
again after each object picked, so what leaned on it falls; after a failed pick, the objects stay where the hand's
one execution of the grasp left them (the protocol's nominal trial, the hand then letting go and parking: what it
pushed or dropped has moved). An object that comes to rest off the table leaves the scene uncleared. Per chooser:
the objects cleared and the rounds' outcomes."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from onepiece_dist.errors import MeshRejected
from onepiece_dist.picks.clutter import (
    ObjectGroup,
    Scene,
    SceneExecutions,
    loaded_scene,
    scene_seed,
    seen_scene,
    settled,
)
from onepiece_dist.picks.object_picks import choose
from onepiece_dist.specs.plan import PickSpec

MAX_FAILURES = 2  # failed rounds in a row that end a clearance (VGN's)
MAX_ROUNDS = 2  # rounds per object at most
ROUNDS_A_VIEW = 100  # a round's seed: view * ROUNDS_A_VIEW + round


@dataclass(frozen=True)
class Clearance:
    """One settled scene cleared by each chooser: per method, each round's outcome (True: an object left)."""

    view: int
    objects: int
    rounds: dict[str, tuple[bool, ...]]

    def cleared(self, method: str) -> int:
        return sum(self.rounds[method])


@dataclass(frozen=True)
class SceneClearances:
    """Every view of one scene cleared; ``status`` 'ok', or 'rejected' with ``reason``."""

    index: int
    name: str
    status: str
    views: tuple[Clearance, ...] = ()
    reason: str = ""
    seconds: float = 0.0


def clear_scenes(spec: PickSpec, group: ObjectGroup, index: int) -> SceneClearances:
    """Each of ``spec.views`` settles of ``group`` cleared by each of ``spec.methods`` (not the full-mesh ones,
    nor the oracle)."""
    start = time.perf_counter()
    try:
        scorer, world, objects = loaded_scene(spec, group)
    except MeshRejected as err:
        return SceneClearances(index, group.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    views = []
    for view in spec.view_indices:
        resting, _ = settled(spec, world, objects, view)
        views.append(Clearance(view, len(objects), {m: _cleared(spec, scorer, world, objects, resting, view, m)
                                                    for m in spec.methods}))
    return SceneClearances(index, group.name, "ok", tuple(views), seconds=time.perf_counter() - start)


def _cleared(spec: PickSpec, scorer, world, objects, resting, view: int, method: str) -> tuple[bool, ...]:
    """Each round's outcome of ``method`` clearing ``objects`` resting at ``resting``."""
    from onepiece_dist.sim.pick import on_table

    left, outcomes, failures, resting = list(range(len(objects))), [], 0, list(resting)
    rng = np.random.default_rng([*scene_seed(spec, objects, view), ROUNDS_A_VIEW])  # the rounds' cameras
    while left and failures < MAX_FAILURES and len(outcomes) < MAX_ROUNDS * len(objects):
        here = tuple(objects[k] for k in left)
        rest = tuple(resting[k] for k in left)
        code = view * ROUNDS_A_VIEW + len(outcomes)
        seen = seen_scene(spec, scorer.record, here, rest, rng, code)
        picked, aimed, after = False, None, None
        if seen.proposals is not None:
            choice = choose(method, spec, scorer, seen, None)
            if len(choice.poses):
                executions = SceneExecutions(spec, world, here, Scene(rest, seen), code)
                aimed = executions.target(choice.poses[0])
                picked = executions.run(choice.pool, choice.indices[0], choice.poses[0]).success
                if spec.pile and not picked:
                    after = executions.aftermath(choice.poses[0])
        outcomes.append(picked)
        failures = 0 if picked else failures + 1
        if picked:
            left.pop(aimed)
            if spec.pile and left:
                resting = resettled(world, objects, resting, left)
        elif after is not None:  # a failed pick in a pile: what it pushed or dropped stays where it came to rest
            for k, pose in zip(left, after, strict=True):
                resting[k] = pose
        if spec.pile:
            left = [k for k in left if on_table(resting[k])]  # what fell off leaves the scene uncleared
    return tuple(outcomes)


def resettled(world, objects, resting: list[np.ndarray], left: list[int]) -> list[np.ndarray]:
    """``resting`` with the objects ``left`` come to rest again where they stood (the picked one gone)."""
    first, *others = left
    objects[first].load_into(world)
    world.set_neighbours(tuple(objects[k].neighbour(resting[k]) for k in others))
    placed = world.settle_in_place(resting[first])
    now = list(resting)
    for k, pose in zip(left, [placed, *world.beside.poses(world.client)], strict=True):
        now[k] = pose
    return now
