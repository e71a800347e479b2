"""The shipped network's recipe made again by the planner as it ships (issue 55). The network shipped for the box
gripper (pick_top_down's seed 0: ``context_balanced`` on the first label batch executing the top-down grasps joined
with the curve's second) was fitted on labels whose candidates were planned with the open gripper 2 mm over the
table, the planner's height then; it plans 8 mm over it since pick_table_gap. Here both batches are labelled again
with today's planner (the same objects, views and seeds; their candidates 8 mm over the table), the same design
fitted on them at each seed, and each network judged as `onepiece pick` judges the shipped one (8 views an object,
its first 3 grasps checked), the network chooser alone, on the household and unseen sets, paired over objects
against the shipped network on the same views.

    .venv/bin/python -m benchmarks.experiments.pick_relabelled [--seeds 0]

Labels: data/pick_labels_gap8mm_top_down/, data/pick_labels2_gap8mm/ (kept where they hold labels of the same
spec); networks: data/pick_curve/relabelled/relabelled_s<seed>/best.pt; results:
benchmarks/results/pick_relabelled.json (a seed already in it is kept), rendered on docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date

from benchmarks.experiments.pick_curve import BATCHES, HERE, OUT, fit, label_spec, labelled
from benchmarks.experiments.pick_own_network import judged
from onepiece_dist.specs.plan import PlanSpec

RESULTS = HERE / "results" / "pick_relabelled.json"
DESIGN = "context_balanced"  # the shipped networks' design
SUFFIX = f"_gap{1000 * PlanSpec().table_clearance:g}mm"


def recipe_specs(suffix: str, gripper: str | None = None) -> list:
    """The shipped network's two label batches' specs, today's planner: [(folder name, spec, shapes folder, shapes
    seed)], the first executing the top-down grasps; each folder named with ``suffix``, labelled by ``gripper`` (a
    preset; None: the default job's box gripper)."""
    made = []
    for (objects, folder, shapes, seed), top_down in zip(BATCHES[:2], (True, False), strict=True):
        name = f"{folder}{suffix}" + ("_top_down" if top_down else "")
        spec = label_spec(objects, name)
        fields = {**spec.model_dump(), "plan": {**spec.plan.model_dump(), "top_down": top_down},
                  **({"gripper": gripper} if gripper else {})}
        made.append((name, type(spec).model_validate(fields), shapes, seed))
    return made


def labelled_batches(specs: list) -> list:
    """``recipe_specs``' batches labelled (here, unless their folders hold them): [(name, labels)]."""
    return [(name, labelled(spec, shapes, seed)) for name, spec, shapes, seed in specs]


def joined(batches: list):
    """The labels of ``labelled_batches``, all joined in order."""
    labels = batches[0][1]
    for _, more in batches[1:]:
        labels = labels.joined(more)
    return labels


def batch_record(name: str, labels) -> dict:
    plan = labels.attrs["spec"]["plan"]
    return {"folder": f"data/{name}", "objects": labels.attrs["spec"]["objects"], "labels": len(labels),
            "success_rate": round(float(labels.success.mean()), 4), "top_down": bool(plan.get("top_down", False)),
            "table_clearance": plan["table_clearance"], "core_seconds": labels.attrs["core_seconds"]}


def shipped_picks() -> dict:
    """The shipped network judged on the same views by the same command (pick_own_network's shipped row, which
    gives picks.json's figures)."""
    return json.loads((HERE / "results" / "pick_own_network.json").read_text())["shipped"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0")
    args = parser.parse_args()
    before = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {"points": []}
    batches = labelled_batches(recipe_specs(SUFFIX))
    labels = joined(batches)
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_relabelled", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "design": DESIGN,
           "batches": [batch_record(name, made) for name, made in batches],
           "shipped": shipped_picks(), "points": before["points"]}

    def write() -> None:
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")

    write()
    for seed in (int(s) for s in args.seeds.split(",")):
        if any(p["seed"] == seed for p in out["points"]):
            continue
        name = f"relabelled_s{seed}"
        point = {"seed": seed, **fit(labels, len(labels), DESIGN, seed, OUT / "relabelled" / name)}
        point["picks"] = judged(HERE.parent / point["checkpoint"], name, None,
                                folder=OUT / "relabelled" / "picks" / name)
        out["points"] = sorted([*out["points"], point], key=lambda p: p["seed"])
        write()
        print(seed, {k: v["first_attempt"] for k, v in point["picks"].items()}, flush=True)


if __name__ == "__main__":
    main()
