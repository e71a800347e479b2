"""Does weighing each patch of B's one object by how many grasps its label stands for lift B to R?

    .venv/bin/python benchmarks/experiment_weighting.py --folder /tmp/exp-full [--radii 0,2]
        [--weightings none,sqrt,count]

B labels each shape once; a uniform batch over its patches treats a shape met once like one met a thousand times,
while R's random subset of candidates follows how often shapes occur. This retrains the B arms of the committed
paper experiment (benchmarks/results/paper_experiment.json; its kept work folder ``--folder`` holds the datasets)
with each patch's loss weighed by its code's grasp count (``unique/count``, the product's train.weight_by_count),
by that count's square root, and not at all ("none": the experiment's own B, trained again as a check), with
everything else as the experiment trained it: network, steps, batch, seeds, the learning rate each arm's
validation split chose, the checkpoint its validation split picks. Held-out: the experiment's.
Writes benchmarks/results/experiment_weighting.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))
from experiment_learn import TrainJob, arm_summary  # noqa: E402
from experiment_train import spawn_context, train_all  # noqa: E402

WEIGHTINGS = ("none", "sqrt", "count")


def weighting_jobs(experiment: dict, folder: Path, radii: list[int], weightings: list[str]) -> list[TrainJob]:
    """Every (radius, weighting, seed) training run of B settled at ``radii``, as the experiment trained B."""
    args, search = experiment["args"], experiment["learning_rate_search"]
    return [TrainJob(f"B r{radius} {weighting}", seed, str(folder / f"B-settled-{radius}.zarr"), "assembled/grasps",
                     None, str(folder / "heldout.zarr"), args["model"], args["steps"], args["batch_size"],
                     search[f"B r{radius}"]["chosen"], 0.2, patch_weighting=weighting)
            for radius in radii for weighting in weightings for seed in range(args["seeds"])]


def summary_rows(experiment: dict, jobs: list[TrainJob], runs: list[dict], labels: np.ndarray,
                 groups: np.ndarray) -> list[dict]:
    """Per (radius, weighting): held-out top-1 and AP over the seeds, beside the experiment's B and R of that
    radius."""
    arms = {row["arm"]: row["heldout"] for row in experiment["arms"]}
    rows = []
    for name in dict.fromkeys(job.arm for job in jobs):
        radius, weighting = name.split()[1], name.split()[2]
        mine = [run for job, run in zip(jobs, runs, strict=True) if job.arm == name]
        held = arm_summary(mine, labels, groups)
        rows.append({"radius": int(radius[1:]), "weighting": weighting,
                     "top1": round(held["top1"]["mean"], 4), "top1_ci95": held["top1"]["ci95"],
                     "ap": round(held["ap"]["mean"], 4), "ap_std": round(held["ap"]["std"], 4),
                     "ap_ci95": held["ap"]["ci95"], "seeds": len(mine),
                     "experiment_b_ap": round(arms[f"B {radius}"]["ap"]["mean"], 4),
                     "experiment_r_ap": round(arms[f"R {radius}"]["ap"]["mean"], 4),
                     "experiment_r_top1": round(arms[f"R {radius}"]["top1"]["mean"], 4)})
    return rows


def main(argv=None) -> dict:
    from onepiece_dist.store import open_dataset

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, required=True, help="the experiment's kept work folder")
    parser.add_argument("--radii", default="0,2")
    parser.add_argument("--weightings", default=",".join(WEIGHTINGS))
    args = parser.parse_args(argv)
    weightings = args.weightings.split(",")
    if unknown := sorted(set(weightings) - set(WEIGHTINGS)):
        parser.error(f"--weightings: {unknown} unknown; choose from {', '.join(WEIGHTINGS)}")
    experiment = json.loads((HERE / "results" / "paper_experiment.json").read_text())
    jobs = weighting_jobs(experiment, args.folder, [int(r) for r in args.radii.split(",")], weightings)
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(2, mp_context=spawn_context()) as pool:
        runs = train_all(jobs, args.folder / "trained", pool)
    heldout = open_dataset(str(args.folder / "heldout.zarr"))
    labels, groups = heldout["grasps/success"].astype(np.float64), heldout["grasps/object"].astype(np.int64)
    out = {"benchmark": "experiment_weighting", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores", "experiment": experiment["command"].strip(),
           "experiment_date": experiment["date"], "model": experiment["args"]["model"],
           "steps": experiment["args"]["steps"], "train_seconds": round(sum(r["train_seconds"] for r in runs), 1),
           "heldout_random_choice": round(experiment["heldout"]["random_choice"], 4),
           "heldout_positive_rate": round(experiment["heldout"]["positive_rate"], 4),
           "rows": summary_rows(experiment, jobs, runs, labels, groups),
           "command": "python benchmarks/experiment_weighting.py " + " ".join(sys.argv[1:] if argv is None else argv)}
    (HERE / "results" / "experiment_weighting.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out["rows"], indent=2))
    return out


if __name__ == "__main__":
    main()
