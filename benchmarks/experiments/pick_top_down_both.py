"""Both label batches executing the top-down grasps (issue 55, next after the kept top-down trial): only the first
batch of that trial executed them, and the shipped network still ranks sampled grasps above the top-down grasp on
flat packages it would hold. The second batch's objects and views labelled again with ``plan.top_down`` join the
trial's first batch; ``context_balanced`` fitted seed for seed against the top-down trial's networks
(results/pick_top_down.json), both planning with the top-down grasps in the pool; kept by the trials' paired rule on
the household set (docs/picks.md), the unseen set reported beside.

    .venv/bin/python -m benchmarks.experiments.pick_top_down_both [--seeds 0,1,2,3] [--label-only]

Results: benchmarks/results/pick_top_down_both.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse

from benchmarks.experiments.pick_curve import BATCHES, label_spec, labelled
from benchmarks.experiments.pick_top_down import fit_seeds, top_down_batch
from benchmarks.experiments.pick_unseen import DESIGN


def second_top_down_batch():
    objects, folder, shapes, seed = BATCHES[1]
    spec = label_spec(objects, folder + "_top_down")
    return labelled(spec.model_copy(update={"plan": spec.plan.model_copy(update={"top_down": True})}), shapes, seed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3")
    parser.add_argument("--label-only", action="store_true", help="make the second batch's labels and stop")
    args = parser.parse_args()
    second = second_top_down_batch()
    if not args.label_only:
        fit_seeds(top_down_batch().joined(second), DESIGN, args.seeds, "both", "top_down", "pick_top_down_both",
                  {"labels": len(second), "success_rate": float(second.success.mean())})


if __name__ == "__main__":
    main()
