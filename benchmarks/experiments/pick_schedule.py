"""The learning rate's schedule (issue 55, how the network learns): the shipped design fits at a constant rate
and stops when the validation AP has not risen for 5 epochs; half the top-down trial's fits stopped by epoch 17,
the others ran all 30. ``context_balanced_cosine`` decays the rate along a cosine over all 30 epochs, never
stopped early, the best epoch by validation AP kept as before; fitted seed for seed on the top-down trial's labels
against that trial's networks, both planning with the top-down grasps in the pool. Kept by the trials' paired rule
on the household set (docs/picks.md), the unseen set reported beside.

    .venv/bin/python -m benchmarks.experiments.pick_schedule [--seeds 0,1,2,3]

Results: benchmarks/results/pick_schedule.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse

from benchmarks.experiments.pick_on_policy import second_batch
from benchmarks.experiments.pick_top_down import fit_seeds, top_down_batch

DESIGN = "context_balanced_cosine"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3")
    args = parser.parse_args()
    fit_seeds(top_down_batch().joined(second_batch(None)), DESIGN, args.seeds, DESIGN, "schedule", "pick_schedule",
              {"design": DESIGN})


if __name__ == "__main__":
    main()
