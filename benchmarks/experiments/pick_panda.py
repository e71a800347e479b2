"""The hand that executes is the hand that labels (issue 55, what to build 4): the shipped network's recipe made
again for the ``panda`` preset, whose physics and collision test carry the Franka hand's own collision mesh
(pybullet_data franka_panda/meshes/collision/hand.obj, 20 cm across the closing axis, where the default
job's box palm spans the 8 cm opening and its two 1 cm fingers). The same two label batches (the first executing
the top-down grasps, the second at random; the same objects, views and seeds) are labelled with that hand,
``context_balanced`` is fitted on them at each seed, and the pick benchmark judges each network beside every
other chooser, all executed by that hand.

    .venv/bin/python -m benchmarks.experiments.pick_panda [--seeds 0,1] [--sets household,unseen,procedural]

Labels: data/pick_labels_panda*/ (skipped where they hold labels of the same spec), planned as the planner plans
today (the open gripper ``PlanSpec().table_clearance`` over the table), and judged by today's planner; the network:
data/pick_curve/panda/gap8mm_panda_s<seed>/best.pt (its folder and the picks' name the labels' height); results:
benchmarks/results/pick_panda.json (a run again judges only the sets not yet in it, and fits again only where the
checkpoint is missing), rendered on docs/picks.md.

The network shipped for the preset (``SHIPPED``) came from this recipe as it ran on 2026-12-05, labelled and judged
with the open gripper 2 mm over the table, the planner's height then: results/pick_panda_2mm.json, kept as it was.
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_clutter import SINGLE, hand_record
from benchmarks.experiments.pick_curve import HERE, OUT, ROOT, fit
from benchmarks.experiments.pick_own_network import height_tag
from benchmarks.experiments.pick_relabelled import batch_record, joined, labelled_batches, recipe_specs
from onepiece_dist.specs.plan import PlanSpec

RESULTS = HERE / "results" / "pick_panda.json"
PICKS = ROOT / "data" / "pick_panda"
GRIPPER = "panda"
SHIPPED = SINGLE[GRIPPER]  # the record the network shipped for the preset came from
DESIGN = "context_balanced"
HEIGHT = height_tag(PlanSpec().table_clearance)  # the networks' and picks' folders name the labels' height


def panda_specs():
    """The shipped network's two label batches' specs with the Franka hand: [(folder name, spec, shapes folder,
    shapes seed)]; each differs from the box palm's only in its gripper and folder."""
    return recipe_specs("_panda", GRIPPER)


def panda_batches():
    """The batches of ``panda_specs`` labelled (here, unless their folders hold them): [(name, labels)]."""
    return labelled_batches(panda_specs())


def network_folder(seed: int, name: str = "panda") -> Path:
    """The folder of the network ``name`` fitted at ``seed`` on labels of this recipe (named by their height: a
    network of labels made at another height is never taken for it)."""
    return OUT / "panda" / f"{HEIGHT}{name}_s{seed}"


def trained(labels, seed: int, before: dict | None) -> dict:
    """``DESIGN`` fitted at ``seed`` on the joined ``labels`` (kept from ``before`` where its checkpoint is still
    there)."""
    if before and (ROOT / before["checkpoint"]).is_file():
        return before
    return fit(labels, len(labels), DESIGN, seed, network_folder(seed))


def judged(point: dict, names: list[str], write) -> dict:
    """``point`` (a seed's network and the sets judged so far) with the sets ``names`` judged too, each written
    (``write``) as it lands."""
    from benchmarks.experiments.picks import run_set, sets

    for name in names:
        if any(s["name"] == name for s in point["sets"]):
            continue
        objects, source = sets()[name]
        result = run_set(name, objects(), source, ROOT / point["network"]["checkpoint"],
                         PICKS / f"{HEIGHT}s{point['seed']}")
        point["sets"] = sorted([*point["sets"], result], key=lambda s: list(sets()).index(s["name"]))
        write()
        print(point["seed"], name, {m["method"]: m["first_attempt"] for m in result["methods"]}, flush=True)
    return point


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1")
    parser.add_argument("--sets", default="household,unseen,procedural")
    args = parser.parse_args()
    before = {p["seed"]: p for p in (json.loads(RESULTS.read_text())["points"] if RESULTS.is_file() else [])}
    batches = panda_batches()
    labels = joined(batches)
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_panda", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", **hand_record(GRIPPER),
           "batches": [batch_record(name, made) for name, made in batches], "points": []}

    def write() -> None:
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")

    for seed in (int(s) for s in args.seeds.split(",")):
        was = before.get(seed, {})
        network = trained(labels, seed, was.get("network"))
        point = {"seed": seed, "network": network, "sets": was.get("sets", []) if was.get("network") == network else []}
        out["points"].append(point)
        judged(point, args.sets.split(","), write)
    write()


if __name__ == "__main__":
    main()
