"""The network's own best grasps drawn again (issue 55: where the ranking errs). A chooser that knew which of
a view's candidates pick again reaches 88.5% of the household views and 80.5% of the unseen ones at the first
attempt (pick_ceiling), the network 85.9% and 70.8%: its first grasps pick less surely than the surest of its pool,
and labels drawn once at random say little about which of a network's best grasps pick again. Here each of the
first label batch's objects is seen at 4 of its views, the shipped network's 8 best-ranked candidates of each
executed 4 times (picks.top_draws), and the rows join the top-down trial's labels with the share of the draws that
picked as their target (``context_balanced_draws``; the other rows' target is their one execution, as before),
each under its object's own index so validation holds an object out whole. Fitted seed for
seed against the top-down trial's networks, both planning with the top-down grasps in the pool; kept by the trials'
paired rule on the household set, the unseen set reported beside.

    .venv/bin/python -m benchmarks.experiments.pick_top_draws [--seeds 0,1]

Results: benchmarks/results/pick_top_draws.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import get_context

import numpy as np

from benchmarks.experiments.pick_curve import ROOT
from benchmarks.experiments.pick_on_policy import second_batch
from benchmarks.experiments.pick_top_down import fit_seeds, top_down_batch

DESIGN = "context_balanced_draws"
WANTED = {"top": 8, "draws": 4, "views": 4}
FOLDER = "data/pick_labels_top_draws"


def _object(task):
    import torch

    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.top_draws import TopDraws, top_draws_object
    from onepiece_dist.specs.plan import PickLabelSpec

    torch.set_num_threads(1)  # one core per process, and the same sums in every process
    spec_json, checkpoint, index = task
    spec = PickLabelSpec.model_validate(spec_json)
    return top_draws_object(spec, resolve_source(spec.objects)[index], index, TopDraws(checkpoint, **WANTED))


def top_draws(first, processes: int = 2):
    """The rows of the first batch's objects (``first``: its labels), made here unless ``FOLDER`` holds them."""
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickLabelSpec
    from onepiece_dist.store.pick_labels import read_pick_labels, write_pick_labels

    path = ROOT / FOLDER / "pick_labels.zarr"
    if path.exists():
        return read_pick_labels(path)
    spec = PickLabelSpec.model_validate({**first.attrs["spec"], "output": FOLDER})
    checkpoint = str(shipped_network())
    tasks = [(spec.model_dump(mode="json"), checkpoint, i) for i in range(len(resolve_source(spec.objects)))]
    start = time.perf_counter()
    with get_context("spawn").Pool(processes) as pool:
        found = list(pool.imap_unordered(_object, tasks))
    write_pick_labels(path, found, {**spec.model_dump(mode="json"), "top_draws": {"checkpoint": "shipped", **WANTED}},
                      sum(o.seconds for o in found), time.perf_counter() - start)
    return read_pick_labels(path)


def with_top_draws(labels, rows):
    """``labels`` (the first batch's first) and ``rows`` of the first batch's objects, each row under its object's
    index there."""
    from onepiece_dist.store.pick_labels import COLUMNS, PickLabels

    def column(name: str) -> np.ndarray:  # a column the labels lack (an empty one per row) the rows drop too
        mine = getattr(rows, name)
        if getattr(labels, name).shape[1:] != mine.shape[1:] and 0 in getattr(labels, name).shape[1:]:
            mine = np.zeros((len(mine), *getattr(labels, name).shape[1:]), mine.dtype)
        return np.concatenate([getattr(labels, name), mine])

    both = {name: column(name) for name in (*COLUMNS, "object")}
    return PickLabels(**both, attrs={**labels.attrs, "core_seconds": labels.attrs["core_seconds"]
                                     + rows.attrs["core_seconds"]})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1")
    args = parser.parse_args()
    first = top_down_batch()
    rows = top_draws(first)
    joined = with_top_draws(first.joined(second_batch(None)), rows)
    fit_seeds(joined, DESIGN, args.seeds, DESIGN, "top_draws", "pick_top_draws",
              {"design": DESIGN, "labels": len(joined), "rows_drawn_again": len(rows),
               "their_draws": WANTED["draws"], "their_mean_picks": round(float(rows.picks.mean()), 4),
               "their_first_draw_rate": round(float(rows.success.mean()), 4),
               "label_core_seconds": rows.attrs["core_seconds"]})


if __name__ == "__main__":
    main()
