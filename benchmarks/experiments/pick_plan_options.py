"""The planner's options judged at 40 views an object (issue 55). The check (``PlanSpec.check_first``) reorders the
network's first 3 grasps by how often each held on the shape the view implies; its gain is bounded by what those
three are. After non-maximum suppression at 1 cm and 30 degrees, the first three can be near copies of one grasp,
which fail together on the true shape: the check then has nothing to choose (the ``nms_`` variants); and where
none of the three held every draw the network's order stands, where later grasps checked might hold (the
``check_more_`` variants: ``PlanSpec.check_more``). The check's shape and draws, last judged with the open gripper
2 mm over the table, are judged again (``carved``, ``check_draws_8``). Each variant changes the planner's spec as
VARIANTS says; the network shipped for the default job's box gripper, its chooser alone, the household and unseen
sets at 40 views an object (the first 8 the benchmark's), paired over objects against the planner's default as
pick_table_gap judged it on the same views and draws (its 8 mm run: the default's height). The ``own_`` variants
plan with networks pick_own_network makes, the ``relabelled_`` ones (never run by default: pick_relabelled makes
their networks first) with the shipped recipe labelled again by today's planner.

    .venv/bin/python -m benchmarks.experiments.pick_plan_options [--variants nms_2cm_45,nms_3cm_60]

Results: benchmarks/results/pick_plan_options.json (a variant run again replaces its own results only), rendered
into docs/picks.md by benchmarks/pages/pick_plan_options_section.py.
"""

from __future__ import annotations

import json
import platform
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_panda_check import slim
from benchmarks.experiments.pick_table_gap import RESULTS as TABLE_GAP
from benchmarks.experiments.pick_table_gap import SETS, VIEWS, network
from benchmarks.pages.pick_sets import paired_first_attempts as paired
from onepiece_dist.specs.plan import PLANNER_CLEARANCE_BEFORE, PlanSpec

RESULTS = HERE / "results" / "pick_plan_options.json"
VIEW_KEPT = ("view", "attempts")  # of each view, what the section reads (each set keeps its first failures' counts)
COMMAND = ".venv/bin/python -m benchmarks.experiments.pick_plan_options"
VARIANTS = {"nms_2cm_45": {"nms_distance": 0.02, "nms_angle_deg": 45.0},  # PlanSpec fields changed
            "nms_3cm_60": {"nms_distance": 0.03, "nms_angle_deg": 60.0},
            "nms_5mm_15": {"nms_distance": 0.005, "nms_angle_deg": 15.0},
            "nms_none": {"nms_distance": 0.0, "nms_angle_deg": 0.0},
            "check_more_3": {"check_more": 3}, "check_more_7": {"check_more": 7},
            "carved": {"check_shape": "carved"}, "check_draws_8": {"check_draws": 8},
            "check_density_100": {"check_density": 100.0}, "check_density_200": {"check_density": 200.0},
            "check_top_down": {"check_top_down": True}}
OWN_OBJECTS = "pybullet:random_urdfs[0:32]+shapes:groceries[0:16]+shapes:vessels[0:16]"  # pick-labels' default
NETWORKS = {f"own_l{label}_f{fit}": (label, fit) for label in (0, 1) for fit in (0, 1)}  # (label seed, fit seed)
RELABELLED = {f"relabelled_s{seed}": seed for seed in (0, 1)}  # pick_relabelled's networks: their fit seed
# pick_own_network's fits from fresh weights on pick-labels' defaults, labelled 2 mm and 8 mm over the table:
# name -> (label seed, fit seed, the labels' height over the table in m)
FRESH = {f"own_{tag}l{label}_f0": (label, 0, height) for label in (0, 1)
         for tag, height in (("fresh_", PLANNER_CLEARANCE_BEFORE), ("gap8mm_", PlanSpec().table_clearance))}


def checkpoint(name: str) -> Path:
    """The network variant ``name`` plans with: where NETWORKS names it, the network pick_own_network made of
    pick-labels' defaults at its label seed and pick-train started from the shipped one at its fit seed (made here
    unless kept); where FRESH does, the same from fresh weights on labels made at its height over the table; where
    RELABELLED does, pick_relabelled's network at its seed; else the network shipped for the box gripper."""
    from benchmarks.experiments import pick_own_network as own

    if name in RELABELLED:
        path = ROOT / "data" / "pick_curve" / "relabelled" / name / "best.pt"
        if not path.is_file():
            raise SystemExit(f"{path}: not here; make it first: .venv/bin/python -m "
                             f"benchmarks.experiments.pick_relabelled --seeds {RELABELLED[name]}")
        return path
    if name not in NETWORKS and name not in FRESH:
        return network("default")
    label, fit, height, start = (*NETWORKS[name], PLANNER_CLEARANCE_BEFORE, "shipped") if name in NETWORKS \
        else (*FRESH[name], None)
    prefix = own.net_prefix(OWN_OBJECTS, start, height)
    path = ROOT / "data" / own.named(None) / own.net_name(prefix, label, fit) / "best.pt"
    if not path.is_file():
        own.network(own.labels(label, None, OWN_OBJECTS, height)[0], label, fit, prefix, start)
    return path


def base_run() -> dict:
    """pick_table_gap's run at the planner's default height: the default planner on the same views and draws."""
    return json.loads(TABLE_GAP.read_text())["runs"][f"{PlanSpec().table_clearance:g}"]


def judged(name: str, base: dict) -> dict:
    """The shipped network's chooser on both sets with the planner's spec changed as VARIANTS[name] says, paired
    over objects against ``base`` per set and over both."""
    from benchmarks.experiments.picks import run_set, sets
    plan, planner = VARIANTS.get(name, {}), checkpoint(name)
    found = {"plan": plan, "views": VIEWS, "sets": [], **({"network": NETWORKS[name]} if name in NETWORKS else {}),
             **({"relabelled": RELABELLED[name]} if name in RELABELLED else {}),
             **({"fresh": dict(zip(("label", "fit", "table_clearance"), FRESH[name], strict=True))}
                if name in FRESH else {})}
    for set_name in SETS:
        objects, source = sets()[set_name]
        found["sets"].append(slim(run_set(set_name, objects(), source, planner, ROOT / "data" / RESULTS.stem / name,
                                          ("network",), PlanSpec(**plan), VIEWS), VIEW_KEPT))
        print(name, set_name, found["sets"][-1]["methods"][0]["first_attempt"], flush=True)
    pairs = {s["name"]: paired([s], [b for b in base["sets"] if b["name"] == s["name"]], "network")
             for s in found["sets"]}
    found["versus"] = {**pairs, "all objects": paired(found["sets"], base["sets"], "network")}
    return found


def write(out: dict) -> None:
    """The results on one line, each view cut to VIEW_KEPT (variants judged before it was kept cut too): indented,
    or with each view's failures, 17 variants of 40 views would pass 2 MiB."""
    for run in out["variants"].values():
        run["sets"] = [slim(s, VIEW_KEPT) for s in run["sets"]]
    RESULTS.write_text(json.dumps(out) + "\n")


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default=",".join(VARIANTS) + "," + ",".join(NETWORKS))
    args = parser.parse_args()
    kept = json.loads(RESULTS.read_text())["variants"] if RESULTS.is_file() else {}
    base = base_run()
    out = {"command": COMMAND, "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "network": network("default").name,
           "base": {"gap": base["gap"], "from": TABLE_GAP.name}, "variants": kept}
    for name in args.variants.split(","):
        out["variants"][name] = judged(name, base)
        write(out)
    print(json.dumps({name: run["versus"] for name, run in out["variants"].items()}, indent=1))


if __name__ == "__main__":
    main()
