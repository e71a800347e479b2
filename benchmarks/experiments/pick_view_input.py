"""Does the network pick better when it knows where the camera was (issue 55, "what lies around the fingers")? A
crop of one depth view holds only the side the camera saw: the direction to the camera, in the gripper frame, says
which side of the closing region was seen and which lies in occluded, unknown space (where a finger may close on
nothing or meet what was not seen).

Networks fitted on the same rows of the first batch of pick labels (data/pick_labels, the learning curve's), the
same design (``context_balanced``) and seed: ``view_input_base`` on the stored context (gravity, object offset),
``view_input`` on that and the direction to the camera (``pointnet_context_view``); and ``view_input_base`` again
with seed 1, the spread of one design by its seed alone. Each label's camera is found again by settling its object
and drawing its view's camera as the labelling did; a view whose candidates do not come out again exactly (the
pick world's history moved its settle: 67 of 2,560 views) is left out of all. Judged by
benchmarks/experiments/pick_rankings.py (rankings ``view_input_base``, ``view_input``, ``view_input_base_seed1``).

    .venv/bin/python -m benchmarks.experiments.pick_view_input eyes   # the cameras (about 10 min, one core)
    .venv/bin/python -m benchmarks.experiments.pick_view_input fit view_input_base   # about 8 min each, one core
    .venv/bin/python -m benchmarks.experiments.pick_view_input fit view_input
    .venv/bin/python -m benchmarks.experiments.pick_view_input fit view_input_base --seed 1
    .venv/bin/python -m benchmarks.experiments.pick_view_input summary   # results/pick_view_input.json
    .venv/bin/python -m benchmarks.experiments.pick_rankings \
        --rankings network,view_input_base,view_input,view_input_base_seed1
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import numpy as np

from benchmarks.experiments.pick_curve import OUT, ROOT
from benchmarks.experiments.view_input_task import LABELS, object_eyes
from onepiece_dist.core.grasp_context import CONTEXT_SIZE, grasp_context

EYES = ROOT / "data" / "pick_view_input" / "eyes.npy"  # rows: object, view, eye x, y, z, matched
MODELS = {"view_input_base": "pointnet_context", "view_input": "pointnet_context_view"}


def eyes() -> None:
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.runner import run_each_in_process
    from onepiece_dist.specs.plan import PickLabelSpec
    from onepiece_dist.store.pick_labels import read_pick_labels

    spec = PickLabelSpec.stored(read_pick_labels(LABELS / "pick_labels.zarr").attrs["spec"])
    rows = [row for rows in run_each_in_process(object_eyes, spec, resolve_source(spec.objects)) for row in rows]
    EYES.parent.mkdir(parents=True, exist_ok=True)
    np.save(EYES, np.array(rows, dtype=np.float64))


def labels_with_view(eye_rows: np.ndarray):
    """The first batch's labels of the matched views, their context followed by the direction to the camera in
    the gripper frame (n, 9)."""
    from onepiece_dist.store.pick_labels import read_pick_labels

    labels = read_pick_labels(LABELS / "pick_labels.zarr")
    key = labels.object.astype(np.int64) * 1000 + labels.view
    table = {int(o) * 1000 + int(v): row for o, v, *row in eye_rows}
    kept = np.flatnonzero([table[int(k)][3] == 1.0 for k in key])
    labels = labels.subset(kept)
    eye = np.array([table[int(k)][:3] for k in key[kept]])
    depth = float(labels.attrs["spec"]["gripper"]["closing_depth"])
    seen = grasp_context(labels.pose, np.zeros(3), np.zeros(3), depth, eye)[:, CONTEXT_SIZE:]  # the camera's part
    return dataclasses.replace(labels, context=np.concatenate([labels.context, seen], axis=1))


def fit(name: str, seed: int = 0) -> dict:
    """Fit network ``name`` (MODELS) with ``seed`` (its validation objects, initial weights and batches) into
    data/pick_curve/NAME (NAME_seedS for another seed)."""
    import torch

    from onepiece_dist.learn.pick_train import PickTrainOptions, train_on_pick_labels

    torch.set_num_threads(1)
    labels = labels_with_view(np.load(EYES))
    if name == "view_input_base":
        labels = dataclasses.replace(labels, context=labels.context[:, :6])
    spec = labels.attrs["spec"]
    crop = {"gripper": spec["gripper"], "voxel": spec["voxel"], "points_per_grasp": spec["points_per_grasp"],
            "source": "pick_labels"}
    folder = OUT / (f"{name}_seed{seed}" if seed else name)
    result = train_on_pick_labels(labels, folder, crop, PickTrainOptions(model=MODELS[name], balanced=True,
                                                                         seed=seed))
    summary = {"name": folder.name, "model": MODELS[name], "labels": len(labels), "seed": seed,
               "fit_seconds": round(result.seconds, 1), "best_epoch": dataclasses.asdict(result.best),
               "epochs": len(result.epochs)}
    (folder / "fit.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


FITS = ("view_input_base", "view_input", "view_input_base_seed1")


def summary() -> dict:
    """The cameras found again and each fit's record (data/pick_curve/NAME/fit.json), as committed results."""
    rows = np.load(EYES)
    out = {"command": "python -m benchmarks.experiments.pick_view_input", "views": len(rows),
           "views_found_again": int(rows[:, 5].sum()),
           "fits": [json.loads((OUT / name / "fit.json").read_text()) for name in FITS]}
    (ROOT / "benchmarks" / "results" / "pick_view_input.json").write_text(json.dumps(out, indent=1) + "\n")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("step", choices=("eyes", "fit", "summary"))
    parser.add_argument("name", nargs="?", choices=tuple(MODELS))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(fit(args.name, args.seed) if args.step == "fit" else {"eyes": eyes, "summary": summary}[args.step]())


if __name__ == "__main__":
    main()
