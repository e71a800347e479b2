"""Other networks ordering the shipped network's best grasps (issue 55: can a network we have find the surer grasp
among the first three?). The views of pick_ranked_draws (the shipped network's 10 best-ranked grasps of every
benchmark view, each executed at 8 draws) are seen again and those grasps scored by the top-down trial's networks
at every seed, their mean, the networks of the drawn-again trial and the shipped network fitted further on the
drawn-again rows alone (pick_rerank_fit) and their mean; each chooses its best among the first k (k = 3, 10),
and its expected first attempt is the share of that grasp's 8 draws that picked. Nothing is chosen
here: the views judge. A view that settles elsewhere when seen again (Bullet keeps a little of what the process
simulated before) is left out, named in the results.

    .venv/bin/python -m benchmarks.experiments.pick_reranked

Results: benchmarks/results/pick_reranked.json, rendered into docs/picks.md.
"""

from __future__ import annotations

import json
import platform
from datetime import date

import numpy as np

from benchmarks.experiments.pick_ceiling import _spec
from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_ranked_draws import RESULTS as RANKED
from benchmarks.experiments.pick_ranked_draws import TOP, seen_again

RESULTS = HERE / "results" / "pick_reranked.json"
NETWORKS = {**{f"top_down_s{s}": f"data/pick_curve/top_down/top_down_s{s}/best.pt" for s in range(4)},
            **{f"top_draws_s{s}": f"data/pick_curve/top_draws/context_balanced_draws_s{s}/best.pt" for s in range(2)},
            **{f"rerank_s{s}": f"data/pick_curve/rerank/rerank_s{s}/best.pt" for s in range(2)}}
MEANS = {"top_down_mean": [f"top_down_s{s}" for s in range(4)], "rerank_mean": ["rerank_s0", "rerank_s1"]}


def _scored(which: str, objects: str, stored: dict) -> tuple[list[dict], list[str]]:
    """Each stored view seen again: its draws and every network's scores of its ranked grasps; views that differ."""
    import torch

    from onepiece_dist.picks.object_picks import process_scorer
    from onepiece_dist.plan.scorer import GraspScorer

    torch.set_num_threads(1)
    spec = _spec(which, objects)
    shipped = process_scorer(spec)
    scorers = {name: GraspScorer(str(ROOT / path), spec.gripper, device="cpu") for name, path in NETWORKS.items()}
    rows, moved = [], []
    for again in seen_again(spec, shipped, objects, stored, TOP, moved):
        view = again.stored
        crops = again.seen.proposals.crops.subset(np.array(again.chosen))
        scores = {name: s.score(crops, spec.plan.batch_size) for name, s in scorers.items()}
        scores.update({name: np.mean([scores[n] for n in parts], axis=0) for name, parts in MEANS.items()})
        rows.append({"shares": np.mean(view["draws"], axis=1), "shipped": np.array(view["scores"]), **scores})
    return rows, moved


def chosen(rows: list[dict], name: str, k: int) -> float:
    """The mean share of draws of the grasp ``name`` scores best among each view's first ``k`` (first on ties)."""
    return float(np.mean([row["shares"][int(np.argmax(row[name][:k]))] for row in rows]))


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    ranked = json.loads(RANKED.read_text())
    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    measured = {}
    for which, objects in sets.items():
        rows, moved = _scored(which, objects, ranked["sets"][which]["rows"])
        names = ["shipped", *NETWORKS, *MEANS]
        measured[which] = {"views": len(rows), "views_elsewhere": moved,
                           "chosen": {name: {str(k): chosen(rows, name, k) for k in (3, 10)} for name in names}}
    RESULTS.write_text(json.dumps({
        "command": ".venv/bin/python -m benchmarks.experiments.pick_reranked", "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "networks": NETWORKS, "means": MEANS,
        "sets": measured}, indent=1) + "\n")
    print(json.dumps({w: m["chosen"] for w, m in measured.items()}, indent=1))


if __name__ == "__main__":
    main()
