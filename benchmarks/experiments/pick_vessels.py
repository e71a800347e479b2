"""Training objects shaped like the households that are lost (issue 55): the shipped design's lost picks are
mostly flat packages, mugs and bowls, kinds its training shapes (boxes 2 cm thick or more, cylinders, capsules,
ellipsoids) lack. A second batch of the same size as the curve's second one (random_urdfs[320:480] and 160 vessels:
flat boxes 1-3.5 cm thin, cups with a handle, thin-walled bowls, bottles with a neck;
benchmarks/experiments/training_shapes.py, vessel_shapes) joins the first batch; ``context_balanced`` is fitted on
it seed for seed against the first batch joined with the curve's second batch (pick_on_policy's random points), and
judged by first-attempt picks on the household set, where it is kept or not, and on the unseen set, where nothing
is chosen.

    .venv/bin/python -m benchmarks.experiments.pick_vessels [--seeds 0,1]

Results: benchmarks/results/pick_vessels.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date

from benchmarks.experiments.pick_curve import HERE, OUT, fit, label_spec, labelled, labels, picks
from benchmarks.experiments.pick_unseen import DESIGN, base_point, judge
from benchmarks.experiments.training_shapes import vessel_shapes

RESULTS = HERE / "results" / "pick_vessels.json"
BATCH = ("pybullet:random_urdfs[320:480]+data/vessels", "pick_labels_vessels", "vessels", 2)


def vessel_batch():
    objects, folder, shapes, seed = BATCH
    return labelled(label_spec(objects, folder), shapes, seed, make=vessel_shapes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1")
    args = parser.parse_args()
    first, second = labels(1), vessel_batch()
    joined = first.joined(second)
    points = json.loads(RESULTS.read_text())["points"] if RESULTS.is_file() else []
    for seed in (int(s) for s in args.seeds.split(",")):
        if any(p["seed"] == seed for p in points):
            continue
        point = fit(joined, len(joined), DESIGN, seed, OUT / f"vessels/vessels_s{seed}")
        point.update(seed=seed, second_success_rate=float(second.success.mean()),
                     picks=picks(point["checkpoint"], 8, name=f"vessels/vessels_s{seed}"),
                     unseen=judge(f"vessels_s{seed}", point["checkpoint"]),
                     base=base_point(seed))
        points.append(point)
        print(seed, point["picks"]["methods"]["network"]["first_attempt"], point["unseen"]["first_attempt"],
              flush=True)
        RESULTS.write_text(json.dumps({
            "command": ".venv/bin/python -m benchmarks.experiments.pick_vessels", "date": date.today().isoformat(),
            "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "batch": BATCH[0],
            "labels": len(second), "success_rate": float(second.success.mean()), "points": points}, indent=1)
                           + "\n")


if __name__ == "__main__":
    main()
