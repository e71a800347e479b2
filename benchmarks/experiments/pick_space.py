"""The hand's swept space as the camera saw it (issue 55, core/cloud/swept_space.py), tried against the shipped
design on the same labels: the first label batch of the pick curve made again (its labels now keep the swept
space), ``context_balanced`` and ``context_space`` fitted at each size with several seeds (each seed draws its own
subset, validation objects and initial weights), each network judged by first-attempt picks on the household views.

    .venv/bin/python -m benchmarks.experiments.pick_space [--sizes 8000,40960] [--seeds 0,1]

The labels of the curve's committed points were made by an earlier pick world (benchmarks/results/pick_curve.json):
a design is compared here only with the shipped design fitted on the same labels, seed for seed. Results:
benchmarks/results/pick_space.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date

from benchmarks.experiments.pick_curve import HERE, OUT, fit, labels, picks

DESIGNS = ("context_balanced", "context_space")
RESULTS = HERE / "results" / "pick_space.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="8000,40960")
    parser.add_argument("--seeds", default="0,1")
    parser.add_argument("--views", type=int, default=8)
    args = parser.parse_args()
    all_labels = labels(1)
    if all_labels.space.shape[1] == 0:
        raise SystemExit("the pick labels carry no swept space: remove data/pick_labels and run this again")
    points = json.loads(RESULTS.read_text())["points"] if RESULTS.is_file() else []
    for size in (int(s) for s in args.sizes.split(",")):
        for seed in (int(s) for s in args.seeds.split(",")):
            for design in DESIGNS:
                if any((p["design"], p["labels"], p["seed"]) == (design, size, seed) for p in points):
                    continue
                name = f"space/{design}_{size}_s{seed}"
                point = fit(all_labels, size, design, seed, OUT / name)
                point.update(seed=seed, views=args.views, picks=picks(point["checkpoint"], args.views, name=name))
                points.append(point)
                print(design, size, seed, point["picks"]["methods"]["network"]["first_attempt"], flush=True)
                _write(all_labels, points)


def _write(all_labels, points: list[dict]) -> None:
    described = {"spec": all_labels.attrs["spec"], "rows": len(all_labels),
                 "success_rate": float(all_labels.success.mean()), "core_seconds": all_labels.attrs["core_seconds"]}
    RESULTS.write_text(json.dumps({
        "command": ".venv/bin/python -m benchmarks.experiments.pick_space", "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "labels": described,
        "points": sorted(points, key=lambda p: (p["labels"], p["seed"], p["design"]))}, indent=1) + "\n")


if __name__ == "__main__":
    main()
