"""Where the ranking loses (issue 55): on each view of the household and unseen sets, the shipped network's 10
best-ranked grasps (the planner's ranking: non-maximum suppression and the top-down grasps in the pool), each
executed at 8 draws (draw 0 the one every chooser meets: picks.draws.ranked_draws). Each grasp's share of its draws
is how sure it is; the first's share is the network's expected first attempt; the best of its first k chosen on
draws 0-3 and judged at draws 4-7 is what choosing among those k by how surely they pick would reach; and how often
its scores order two of them as their shares do says how much the ranking knows there.

    .venv/bin/python -m benchmarks.experiments.pick_ranked_draws

Results: benchmarks/results/pick_ranked_draws.json, rendered into docs/picks.md.
"""

from __future__ import annotations

import json
import platform
import time
from dataclasses import dataclass
from datetime import date
from itertools import combinations
from multiprocessing import get_context

import numpy as np

from benchmarks.experiments.pick_ceiling import _spec
from benchmarks.experiments.pick_curve import HERE

RESULTS = HERE / "results" / "pick_ranked_draws.json"
TOP, DRAWS = 10, 8


@dataclass(frozen=True)
class SeenAgain:
    """A stored view of these results seen again: the object's ``number`` in its set, its ``ref``, the pick
    ``world`` and ``mesh``, the ``stored`` view, the view as seen now, the network's ``scores`` of every proposal,
    its ``ranked`` grasps and their indices among the proposals (``chosen``)."""

    number: int
    ref: object
    world: object
    mesh: object
    stored: dict
    seen: object
    scores: np.ndarray
    ranked: tuple
    chosen: list[int]


def seen_again(spec, scorer, objects: str, stored: dict, top: int, moved: list[str]):
    """Each view of ``stored`` (these results' rows of one set, by object name) of ``objects`` seen again with
    ``spec`` and ranked by ``scorer``'s network, its first ``top``, as a SeenAgain; a view whose ranking differs from
    the stored one (Bullet keeps a little of what the process simulated before, and the view settled elsewhere)
    is named in ``moved`` instead."""
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.views import observe_view, ranked_indices, simulated_object

    for number, ref in enumerate(resolve_source(objects)):
        world, loaded = simulated_object(spec, scorer.record, ref)
        for view in stored.get(ref.name, []):
            seen = observe_view(spec, scorer.record, world, loaded.mesh, view["view"])
            scores = scorer.score(seen.proposals.crops, spec.plan.batch_size)
            ranked, chosen = ranked_indices(seen.proposals, scores, scorer.record, spec.plan, top)
            if np.allclose([g.score for g in ranked], view["scores"][:top], atol=1e-5):
                yield SeenAgain(number, ref, world, loaded.mesh, view, seen, scores, ranked, chosen)
            else:
                moved.append(f"{ref.name} view {view['view']}")


def _object(task) -> tuple:
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.draws import ranked_draws

    spec, index = task
    return ranked_draws(spec, resolve_source(spec.objects)[index], index, TOP, DRAWS)


def summary(views: list[dict]) -> dict:
    """The views' means: the first grasp's share of draws; the best of the first 3 and 10 chosen on the first half
    of their draws and judged on the other half (a share chosen on the draws that judge it would flatter it); the
    share of the top-down grasps and of the others among them; and how often two grasps of different shares are
    ordered by score as by share."""
    seen = [(np.asarray(v["scores"]), np.asarray(v["draws"], float), np.asarray(v["top_down"], bool))
            for v in views if v["draws"]]
    half = len(seen[0][1][0]) // 2 if seen else 0
    pairs = [(scores[a] > scores[b]) == (shares[a] > shares[b]) for scores, draws, _ in seen
             for shares in [draws.mean(axis=1)]
             for a, b in combinations(range(len(shares)), 2) if shares[a] != shares[b]]

    def best_of(k: int) -> float:  # the first on ties, as a ranking would take it
        return float(np.mean([draws[int(np.argmax(draws[:k, :half].mean(axis=1))), half:].mean()
                              for _, draws, _ in seen]))

    top_down = np.concatenate([d[is_top].mean(axis=1) for _, d, is_top in seen]) if seen else np.zeros(0)
    others = np.concatenate([d[~is_top].mean(axis=1) for _, d, is_top in seen]) if seen else np.zeros(0)
    return {"views": len(seen), "first": float(np.mean([draws[0].mean() for _, draws, _ in seen])),
            "first_draw0": float(np.mean([draws[0, 0] for _, draws, _ in seen])),
            "first_judged": float(np.mean([draws[0, half:].mean() for _, draws, _ in seen])),
            "best_of_3": best_of(3), "best_of_10": best_of(10),
            "pairs_in_order": float(np.mean(pairs)) if pairs else None, "pairs": len(pairs),
            "top_down_share": float(top_down.mean()) if len(top_down) else None, "top_down_grasps": len(top_down),
            "other_share": float(others.mean()) if len(others) else None}


def measure(name: str, objects: str, processes: int = 1) -> dict:
    from onepiece_dist.objects import resolve_source

    spec = _spec(name, objects)
    start = time.perf_counter()
    with get_context("spawn").Pool(processes) as pool:
        found = sorted(pool.imap_unordered(_object, [(spec, i) for i in range(len(resolve_source(objects)))]))
    per_object = {object_name: [{"view": v.view, "scores": [round(s, 6) for s in v.scores],
                                 "draws": [[int(d) for d in row] for row in v.draws], "top_down": list(v.top_down)}
                                for v in views] for _, object_name, views, reason in found if not reason}
    every = [v for views in per_object.values() for v in views]
    return {**summary(every), "per_object": {n: summary(v) for n, v in per_object.items()},
            "rows": per_object, "seconds": round(time.perf_counter() - start, 1)}


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    measured = {name: measure(name, objects) for name, objects in sets.items()}
    RESULTS.write_text(json.dumps({
        "command": ".venv/bin/python -m benchmarks.experiments.pick_ranked_draws", "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "top": TOP, "draws": DRAWS,
        "sets": measured}, indent=1) + "\n")
    print({name: {k: m[k] for k in ("first", "best_of_3", "best_of_10", "pairs_in_order")}
           for name, m in measured.items()})


if __name__ == "__main__":
    main()
