"""Several objects on the table (docs/picks.md): the pick benchmark has one object on its table; a robot's table
holds several. Scenes of 2 and of 4 objects, run as `onepiece pick --clutter N` runs them
(onepiece_dist/picks/clutter.py, on the embedded Ray): each object of the household and unseen sets with the
next N-1 of its set (wrapping round, so each object stands in N scenes), 8 seeded views a scene; each next object
dropped 1-5 cm beyond those already there along a seeded direction, all settled, one camera aimed at their
middle. A grasp picks when it lifts and holds the object it closes on, the others beside it in every trial.

Runs (the same views, each candidate's outcome its own seeded execution, so the runs compare view for view):
- ``default``: the planner as it ships (the view's objects told apart, its first 3 checked) beside a random
  collision-free candidate, the antipodal score and top-down on the largest object;
- ``unchecked``: the network's order alone (check_first=0);
- ``as_one``: the planner that takes the whole cloud for one object (objects_apart=False), and top-down on it.

    .venv/bin/python -m benchmarks.experiments.pick_clutter [--gripper panda] [--pile]

Results: benchmarks/results/pick_clutter.json, rendered into docs/picks.md. With --gripper panda, the ``default``
run alone with the network shipped for the Franka hand, every grasp executed by that hand:
benchmarks/results/pick_clutter_panda.json. With --pile, the ``default`` run alone on scenes where each next
object is dropped onto those already there (its middle within 3 cm of theirs: `onepiece pick --pile`):
benchmarks/results/pick_clutter_pile.json (pick_clutter_panda_pile.json with --gripper panda).
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date

import numpy as np

from benchmarks.experiments.pick_curve import HERE, ROOT

RESULTS = HERE / "results" / "pick_clutter.json"
SIZES, VIEWS, ATTEMPTS = (2, 4), 8, 3
RUNS = {"default": ({}, ("network", "random", "analytic", "top_down")),
        "unchecked": ({"check_first": 0}, ("network",)),
        "as_one": ({"objects_apart": False}, ("network", "top_down"))}
COMPARED = {"checked_vs_unchecked": ("default", "network", "unchecked", "network"),
            "apart_vs_as_one": ("default", "network", "as_one", "network"),
            "network_vs_top_down": ("default", "network", "default", "top_down")}


def shipped_for(gripper: str | None):
    """The network shipped for the preset ``gripper`` (None: the default job's gripper's) and that gripper."""
    from onepiece_dist.gripper.presets import gripper_fields
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.job import GripperSpec

    hand = None if gripper is None else GripperSpec.model_validate(gripper_fields(gripper))
    return shipped_network(hand), hand


def hand_record(gripper: str | None) -> dict:
    """What a result records of the preset ``gripper`` (nothing for the default job's gripper): its name and the
    solver iterations its worlds step with (sim.world.physics_for: more for a stronger grip)."""
    from onepiece_dist.sim.world import physics_for

    if gripper is None:
        return {}
    return {"gripper": gripper, "solver_iterations": physics_for(shipped_for(gripper)[1]).solver_iterations}


def scene_folder(gripper: str | None, pile: bool) -> str:
    """The data folder (under data/) of the scenes' runs for the preset ``gripper`` (None: the default job's),
    laid apart or in a ``pile``."""
    return "pick_clutter" + (f"_{gripper}" if gripper else "") + ("_pile" if pile else "")


def _spec(name: str, objects: str, size: int, run: str, gripper: str | None = None, pile: bool = False):
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    plan, methods = RUNS[run]
    network, hand = shipped_for(gripper)
    return PickSpec(objects=objects, checkpoint=str(network), gripper=hand, clutter=size,
                    output=str(ROOT / "data" / scene_folder(gripper, pile) / name), views=VIEWS, attempts=ATTEMPTS,
                    pictures=0, methods=methods, plan=PlanSpec(**plan), workers=2, pile=pile)


def measure(name: str, objects: str, size: int, run: str, gripper: str | None = None, pile: bool = False) -> dict:
    """One set's scenes of ``size`` in one run (`onepiece pick --clutter`, on the embedded Ray; ``gripper``: a
    preset, its shipped network planning; ``pile``: each next object dropped onto those there): its summary over
    scenes and each scene's first picks per method."""
    from onepiece_dist.picks.runner import run_picks

    spec = _spec(name, objects, size, run, gripper, pile)
    start = time.perf_counter()
    report = run_picks(spec)
    return {"methods": {m.method: {"first_attempt": m.first_attempt, "interval": list(m.first_attempt_interval),
                                   "within_3": m.within_k, "views": m.views, "failures": m.first_failures}
                        for m in report.methods},
            "per_scene": {m: report.first_picks(m) for m in spec.methods},
            "rejected": {p.name: p.reason for p in report.objects if p.status != "ok"},
            "verdict": report.verdict, "seconds": round(time.perf_counter() - start, 1)}


def paired(scenes: dict, run: str, method: str, base: str, base_method: str = "network") -> dict:
    """``run``'s ``method`` against ``base``'s ``base_method`` on the same views of ``scenes`` (one size's sets),
    first attempt, paired over scenes (each set and all pooled): the mean difference and its 95% bootstrap
    interval."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    per_set = {}
    for name, runs in scenes["sets"].items():
        tried, against = runs[run]["per_scene"][method], runs[base]["per_scene"][base_method]
        per_set[name] = [(tried[p] - against[p]) / VIEWS for p in sorted(set(tried) & set(against))]
    per_set["all scenes"] = [d for diffs in list(per_set.values()) for d in diffs]
    return {name: {"mean": float(np.mean(d)) if d else 0.0, "interval": list(bootstrap_interval(np.array(d)))}
            for name, d in per_set.items()}


# the one-object run each hand's shipped network came from (pick_panda.SHIPPED reads it here)
SINGLE = {"panda": HERE / "results" / "pick_panda_2mm.json"}


def single_rates(gripper: str | None = None) -> dict:
    """Per set and method, the one-object benchmark's first attempt on the same objects (committed picks.json;
    with ``gripper`` panda, the Franka hand's seed-0 network's, pick_panda_2mm.json)."""
    if gripper is None:
        sets = json.loads((HERE / "results" / "picks.json").read_text())["sets"]
    else:
        if gripper not in SINGLE:
            raise ValueError(f"no one-object benchmark of the {gripper!r} hand's network: only {', '.join(SINGLE)}'s")
        sets = json.loads(SINGLE[gripper].read_text())["points"][0]["sets"]
    return {s["name"]: {m["method"]: m["first_attempt"] for m in s["methods"]} for s in sets}


def measure_size(sets: dict, size: int, runs: tuple[str, ...], gripper: str | None = None, pile: bool = False
                 ) -> dict:
    scenes = {"sets": {name: {run: measure(name, objects, size, run, gripper, pile) for run in runs}
                       for name, objects in sets.items()}}
    return {**scenes, **{key: paired(scenes, *how) for key, how in COMPARED.items()
                         if how[0] in runs and how[2] in runs}}


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gripper", choices=("panda",), default=None,
                        help="the preset whose shipped network plans and whose hand executes (the default run alone)")
    parser.add_argument("--pile", action="store_true",
                        help="each next object dropped onto those there (the default run alone)")
    args = parser.parse_args()
    runs = tuple(RUNS) if args.gripper is None and not args.pile else ("default",)
    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    command = (".venv/bin/python -m benchmarks.experiments.pick_clutter" + (f" --gripper {args.gripper}"
                                                                             if args.gripper else "")
               + (" --pile" if args.pile else ""))
    result = {"command": command, "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "views": VIEWS,
              "attempts": ATTEMPTS, **hand_record(args.gripper), **({"pile": True} if args.pile else {}),
              "runs": {run: {"plan": RUNS[run][0], "methods": list(RUNS[run][1])} for run in runs},
              "single": single_rates(args.gripper),
              "scenes": {str(size): measure_size(sets, size, runs, args.gripper, args.pile) for size in SIZES}}
    path = HERE / "results" / ("pick_clutter" + (f"_{args.gripper}" if args.gripper else "")
                               + ("_pile" if args.pile else "") + ".json")
    path.write_text(json.dumps(result, indent=1) + "\n")
    print({size: {name: {run: {m: round(v["first_attempt"], 3) for m, v in r["methods"].items()}
                         for run, r in runs.items()} for name, runs in scenes["sets"].items()}
           for size, scenes in result["scenes"].items()})


if __name__ == "__main__":
    main()
