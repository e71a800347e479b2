"""On-policy pick labels (issue 55): does labelling the network's own first choices teach the ranking what random
labels do not? The pick curve's first batch (random candidates) fits a network; the second batch's objects and views
are then labelled twice, each view's 16 candidates once at random and once half from that network's best-scored
(the rest at random); ``context_balanced`` (the shipped design) is fitted on the first batch joined with each, the
same size, and each is judged by first-attempt picks on the household views.

    .venv/bin/python -m benchmarks.experiments.pick_on_policy [--seeds 0]

Results: benchmarks/results/pick_on_policy.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date

from benchmarks.experiments.pick_curve import BATCHES, HERE, OUT, ROOT, fit, label_spec, labelled, labels, picks

RESULTS = HERE / "results" / "pick_on_policy.json"
POLICY = ("context_balanced", 40960, 0)  # the first batch's network that chooses (pick_space's point)
TOP_SHARE = 0.5


def second_batch(policy: str | None):
    """The second batch's objects and views labelled at random, or with ``policy`` choosing half of each view's."""
    objects, folder, shapes, seed = BATCHES[1]
    spec = label_spec(objects, folder + ("_policy" if policy else ""))
    if policy:
        spec = spec.model_copy(update={"checkpoint": policy, "top_share": TOP_SHARE})
    return labelled(spec, shapes, seed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0")
    parser.add_argument("--views", type=int, default=8)
    args = parser.parse_args()
    first = labels(1)
    design, size, seed = POLICY
    policy = json.loads((HERE / "results" / "pick_space.json").read_text())["points"]
    chooser = next(p for p in policy if (p["design"], p["labels"], p["seed"]) == POLICY)
    checkpoint = str(ROOT / chooser["checkpoint"])
    sets = {"random": first.joined(second_batch(None)), "on_policy": first.joined(second_batch(checkpoint))}
    points = json.loads(RESULTS.read_text())["points"] if RESULTS.is_file() else []
    for seed in (int(s) for s in args.seeds.split(",")):
        for name, joined in sets.items():
            if any((p["second_batch"], p["seed"]) == (name, seed) for p in points):
                continue
            folder = f"on_policy/{name}_s{seed}"
            point = fit(joined, len(joined), design, seed, OUT / folder)
            point.update(second_batch=name, seed=seed, views=args.views, second_success_rate=float(
                joined.success[len(first):].mean()), picks=picks(point["checkpoint"], args.views, name=folder))
            points.append(point)
            print(name, seed, point["picks"]["methods"]["network"]["first_attempt"], flush=True)
            RESULTS.write_text(json.dumps({
                "command": ".venv/bin/python -m benchmarks.experiments.pick_on_policy",
                "date": date.today().isoformat(), "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}",
                "policy": {"checkpoint": chooser["checkpoint"], "design": design, "labels": size,
                           "first_attempt": chooser["picks"]["methods"]["network"]["first_attempt"],
                           "top_share": TOP_SHARE},
                "points": points}, indent=1) + "\n")


if __name__ == "__main__":
    main()
