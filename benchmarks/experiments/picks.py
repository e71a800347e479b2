"""The pick benchmark's committed run (docs/picks.md): the network trained by the study's cheapest plan, judged by
picks from one depth view on real household meshes (robosuite's, fetched by benchmarks/experiments/household.py) and on
held-out procedural objects, beside a random grasp, the analytic score and the same network on full-mesh
candidates.

    .venv/bin/python -m benchmarks.experiments.picks [--checkpoint PATH]

Without --checkpoint it trains first: `onepiece run examples/picks_train.yaml` (a random 3% of 64 x 200
candidates labelled by 4 trials, every one to hold; single-view crops), into data/picks_train.zarr. Results:
benchmarks/results/picks.json and a few pictures in docs/picks/, rendered into docs/picks.md by
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
VIEWS, ATTEMPTS, PICTURES = 4, 3, 2
PICTURE_DIR = ROOT / "docs" / "picks"
TARGETS = {"first_attempt": 0.85, "full_mesh_gap": 0.05}


def trained_checkpoint() -> tuple[Path, dict]:
    """The cheapest plan's network (trained here unless it already is) and what its job measured."""
    from onepiece_dist.api import read_status, run_job
    from onepiece_dist.spec import load_job_spec

    spec = load_job_spec(TRAIN_SPEC, {"output": str(TRAIN_OUT)})
    checkpoint = Path(f"{TRAIN_OUT}.train") / "best.pt"
    status = read_status(TRAIN_OUT) if checkpoint.is_file() else run_job(spec)
    return checkpoint, training_summary(status)


def training_summary(status) -> dict:
    labels, training = status.labels, status.training
    return {"spec": str(TRAIN_SPEC.relative_to(ROOT)), "candidates": status.progress.grasps,
            "labels": labels.labelled_grasps if labels else None,
            "label_success_rate": labels.success_rate if labels else None,
            "validation_ap": training.final.get("val_ap") if training else None,
            "epochs": training.epochs if training else None}


def run_set(name: str, objects: str, source: str, checkpoint: Path, folder: Path) -> dict:
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.plan_spec import PickSpec

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
    args = parser.parse_args()
    checkpoint, training = (args.checkpoint, {"checkpoint": str(args.checkpoint)}) if args.checkpoint else \
        trained_checkpoint()
    folder = ROOT / "data" / "picks"
    household = "robosuite==1.5.2's object meshes, scaled as its models say (benchmarks/experiments/household.py)"
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
