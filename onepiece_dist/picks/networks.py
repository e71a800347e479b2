"""Many networks judged by the same picks (a study judged by picks, docs/study.md): each held-out object settled on
the table and seen once per view exactly as the pick benchmark does (picks.object_picks), the planner's candidates
proposed once per view, and every network's top-ranked candidate executed by the label protocol.

Every network meets the same views and the same candidates; a candidate's execution draws its perturbations from
a generator of its own ([content id, seed, view, candidate]), so its perturbations do not depend on which network
chose it or in what order: one execution per distinct chosen candidate serves every network that chose it (the
same networks give the same bytes; other networks, other earlier executions, can move a rare outcome:
sim.pick.execute_pick). A random
collision-free candidate per view (seeded) gives the guess's rate, to say whether the picks can separate a network
from a guess.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, resolve_source
from onepiece_dist.picks.views import Executions, index_of, observe_view, simulated_object
from onepiece_dist.plan.planner import rank
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.runtime.pinned_child import PinnedSimulation
from onepiece_dist.specs.plan import PickSpec


@dataclass(frozen=True)
class NetworkPicks:
    """One object: per view, whether each network's first choice was picked (views x networks) and whether the
    random candidate was; ``status`` 'ok' or 'rejected' with ``reason``."""

    index: int
    name: str
    status: str
    picked: tuple[tuple[bool, ...], ...] = ()
    random: tuple[bool, ...] = ()
    reason: str = ""
    seconds: float = 0.0


def scored_world(spec: PickSpec, checkpoints: tuple[str, ...], ref: ObjectRef):
    """One scorer per network (on a CPU thread of its own) and the pick world holding ``ref``: (scorers, world,
    loaded object); a bad object raises MeshRejected."""
    import torch

    torch.set_num_threads(1)
    scorers = [GraspScorer(path, spec.gripper, device="cpu") for path in checkpoints]
    return (scorers, *simulated_object(spec, scorers[0].record, ref))


def pick_with_networks(spec: PickSpec, checkpoints: tuple[str, ...], ref: ObjectRef, index: int) -> NetworkPicks:
    """Every view of one object, every network's first choice executed (a bad object: a rejected result)."""
    start = time.perf_counter()
    try:
        scorers, world, loaded = scored_world(spec, checkpoints, ref)
    except MeshRejected as err:
        return NetworkPicks(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    views = [_view(spec, scorers, world, loaded.mesh, view) for view in spec.view_indices]
    return NetworkPicks(index, ref.name, "ok", tuple(v[0] for v in views), tuple(v[1] for v in views),
                        seconds=time.perf_counter() - start)


def _view(spec: PickSpec, scorers: list[GraspScorer], world, mesh, view: int) -> tuple[tuple[bool, ...], bool]:
    seen = observe_view(spec, scorers[0].record, world, mesh, view)
    proposals = seen.proposals
    if proposals is None or len(proposals.poses) == 0:
        return (False,) * len(scorers), False
    executions = Executions(spec, world, mesh, seen.resting, view)

    def picked(candidate: int) -> bool:
        return executions.run("view", candidate, proposals.poses[candidate]).success

    choices = []
    for scorer in scorers:
        best = rank(proposals, scorer.score(proposals.crops, spec.plan.batch_size), scorer.record, spec.plan, keep=1)
        choices.append(picked(index_of(proposals.poses, best[0].pose)) if best else False)
    guess = int(np.random.default_rng([int(mesh.content_id[:16], 16), spec.seed, view]).integers(len(proposals.poses)))
    return tuple(choices), picked(guess)


def run_network_picks(spec: PickSpec, checkpoints: tuple[str, ...]) -> list[NetworkPicks]:
    """Every object of ``spec.objects``, one at a time in a pinned simulation process (runtime.pinned_child)."""
    Path(spec.output).mkdir(parents=True, exist_ok=True)
    simulate, results = PinnedSimulation(), []
    try:
        for index, ref in enumerate(resolve_source(spec.objects)):
            results.append(simulate(pick_with_networks, spec, checkpoints, ref, index))
    finally:
        simulate.close()
    return results
