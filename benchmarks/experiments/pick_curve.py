"""The pick learning curve and the design trials of issue 55 (docs/picks.md): networks fitted on pick labels
(picks.pick_labels: training objects settled on the table, seen as the benchmark sees them, candidates executed by
the pick protocol) at several label counts and designs, each judged by first-attempt picks on the household
objects from one view.

    .venv/bin/python -m benchmarks.experiments.pick_curve [--sizes 500,2000,8000,32000] [--views 8]

Steps: (1) label (BATCHES; --batches 2 and 3 add the others): random_urdfs[0:160] and 160 seeded household-sized
shapes (benchmarks/experiments/training_shapes.py), then random_urdfs[160:320] and [320:480], each with 160 more
shapes, 8 views each, 16 candidates executed per view, on the embedded Ray (skipped where
data/pick_labels*/pick_labels.zarr holds labels of the same spec); (2) per design and size, a network fitted on a
seeded random subset of the labels (validation: 10% of the objects); (3) each network's picks on the household set
(benchmarks/experiments/household.py), the network chooser alone. Core-seconds of a point: the labelling's
core-seconds in proportion to its labels, plus the fit's. Results: benchmarks/results/pick_curve.json; the network
to ship is chosen from them by benchmarks/experiments/ship_network.py.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from dataclasses import asdict, replace
from datetime import date
from pathlib import Path

import numpy as np

from onepiece_dist.learn.pick_network import DESIGNS, pick_crop

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
OUT = ROOT / "data" / "pick_curve"
TRAIN_OBJECTS = "pybullet:random_urdfs[0:160]+data/shapes"
TRIAL_DESIGNS = {  # designs tried beside the curve, never on it: name -> PickTrainOptions fields
    "context_balanced_256": {"model": "pointnet_context", "balanced": True, "points": 256},
    "context_balanced_cosine": {"model": "pointnet_context", "balanced": True, "schedule": "cosine"},
    "context_balanced_outline": {"model": "pointnet_context_outline", "balanced": True},
    "context_balanced_draws": {"model": "pointnet_context", "balanced": True, "target": "draws"},
}


# the labels' batches: (objects, folder, shapes folder, shapes seed); each adds as many labels again
BATCHES = ((TRAIN_OBJECTS, "pick_labels", "shapes", 0),
           ("pybullet:random_urdfs[160:320]+data/shapes2", "pick_labels2", "shapes2", 1),
           ("pybullet:random_urdfs[320:480]+data/shapes3", "pick_labels3", "shapes3", 2))


def label_spec(objects: str, folder: str):
    from onepiece_dist.specs.plan import PickLabelSpec

    return PickLabelSpec(objects=objects, output=f"data/{folder}", views=8, per_view=16, plan={"top_down": False})


def labels(batches: int = 1):
    """The pick labels of the first ``batches`` batches (each made here unless it already is, for the same
    spec), joined."""
    joined = None
    for objects, folder, shapes, seed in BATCHES[:batches]:
        batch = labelled(label_spec(objects, folder), shapes, seed)
        joined = batch if joined is None else joined.joined(batch)
    return joined


def labelled(spec, shapes: str | None, seed: int = 0, make=None):
    """The pick labels of ``spec`` (made here unless its folder holds labels of the same spec), its training shapes
    (``data/<shapes>``, seeded; ``make``: training_shapes unless another maker is given; None: the spec's objects
    need none) made first."""
    from benchmarks.experiments.training_shapes import training_shapes
    from onepiece_dist.picks.pick_labels import run_pick_labels
    from onepiece_dist.store.pick_labels import read_pick_labels

    path = ROOT / spec.output / "pick_labels.zarr"
    if not (path.exists() and type(spec).stored(read_pick_labels(path).attrs["spec"]) == spec):
        if shapes is not None:
            (make or training_shapes)(ROOT / "data" / shapes, 160, seed)
        run_pick_labels(spec)
    return read_pick_labels(path)


def fit(all_labels, size: int, design: str, seed: int = 0, folder: Path | None = None) -> dict:
    rows = np.sort(np.random.default_rng([seed, size]).permutation(len(all_labels))[:size])
    return fit_rows(all_labels, rows, design, seed, folder or OUT / f"{design}_{size}")


def fit_rows(all_labels, rows: np.ndarray, design: str, seed: int, folder: Path) -> dict:
    """A network of ``design`` fitted at ``seed`` on the labels' ``rows``, kept in ``folder``: its record."""
    from onepiece_dist.learn.pick_train import PickTrainOptions, train_on_pick_labels

    subset = all_labels.subset(rows)
    options = replace(PickTrainOptions(seed=seed), **{**DESIGNS, **TRIAL_DESIGNS}[design])
    result = train_on_pick_labels(subset, folder, pick_crop(all_labels), options)
    label_seconds = all_labels.attrs["core_seconds"] * len(rows) / len(all_labels)
    return {"design": design, "labels": len(rows), "options": asdict(options),
            "checkpoint": str(result.checkpoint.relative_to(ROOT)), "fit_seconds": round(result.seconds, 1),
            "label_core_seconds": round(label_seconds, 1),
            "core_seconds": round(label_seconds + result.seconds, 1), "success_rate": result.success_rate,
            "best_epoch": asdict(result.best), "epochs": len(result.epochs)}


def picks(checkpoint: str, views: int, methods: tuple[str, ...] = ("network",), name: str = "household") -> dict:
    from benchmarks.experiments.household import household_objects
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec

    spec = PickSpec(objects=str(household_objects()), checkpoint=str(ROOT / checkpoint),
                    output=str(OUT / "picks" / name), views=views, attempts=3, pictures=0, methods=methods,
                    plan={"top_down": False, "check_first": 0})  # the curve's pool: the view's sampled candidates alone
    start = time.perf_counter()
    report = run_picks(spec)
    summary = {m.method: {"first_attempt": m.first_attempt, "interval": list(m.first_attempt_interval),
                          "within_k": m.within_k, "failures": m.first_failures} for m in report.methods}
    return {"methods": summary, "per_object": {m.method: report.first_picks(m.method) for m in report.methods},
            "verdict": report.verdict, "seconds": round(time.perf_counter() - start, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="500,2000,8000,32000")
    parser.add_argument("--designs", default=",".join(DESIGNS))
    parser.add_argument("--views", type=int, default=8)
    parser.add_argument("--batches", type=int, default=1, help="label batches to use (BATCHES)")
    parser.add_argument("--rejudge", action="store_true", help="judge the committed points' networks again")
    args = parser.parse_args()
    all_labels = labels(args.batches)
    sizes = [min(int(s), len(all_labels)) for s in args.sizes.split(",")]
    path = HERE / "results" / "pick_curve.json"
    done = json.loads(path.read_text())["points"] if path.is_file() else []
    points = [rejudged(p) for p in done] if args.rejudge else list(done)
    if args.rejudge:
        _write(path, all_labels, points)
    for design in args.designs.split(","):
        for size in sizes:
            if any(p["design"] == design and p["labels"] == size and p.get("views") == args.views for p in points):
                continue
            point = fit(all_labels, size, design)
            point.update(views=args.views, batches=args.batches,
                         picks=picks(point["checkpoint"], args.views, name=f"{design}_{size}"))
            points.append(point)
            print(design, size, point["picks"]["methods"]["network"]["first_attempt"], flush=True)
            _write(path, all_labels, points)


def rejudged(point: dict) -> dict:
    """``point`` with its network's picks measured again (after a change to the pick world)."""
    judged = {**point, "picks": picks(point["checkpoint"], point["views"], name=f"{point['design']}_{point['labels']}")}
    print(point["design"], point["labels"], judged["picks"]["methods"]["network"]["first_attempt"], flush=True)
    return judged


def _write(path: Path, all_labels, points: list[dict]) -> None:
    """The results, with the labels described as the most batches written so far (a run on fewer batches keeps
    that description: its points say how many batches they drew from)."""
    labels = {"spec": all_labels.attrs["spec"], "specs": all_labels.attrs.get("specs"), "rows": len(all_labels),
              "success_rate": float(all_labels.success.mean()), "core_seconds": all_labels.attrs["core_seconds"],
              "objects": sum(o["status"] == "ok" for o in all_labels.attrs["objects"])}
    kept = json.loads(path.read_text())["labels"] if path.is_file() else None
    if kept is not None and kept["rows"] > labels["rows"]:
        labels = kept
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_curve", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "labels": labels, "points": points}
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
