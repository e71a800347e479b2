"""Two objects on the table (docs/picks.md): the pick benchmark has one object on its table; a robot's table holds
several. Each object of the household and unseen sets stands in two pairs (with the next object of its set, and
the last with the first), 8 seeded views a pair, run as `onepiece pick --pairs` runs them
(onepiece_dist/picks/pairs.py, on the embedded Ray): the second object dropped 1-5 cm beyond the first along a
seeded direction, both settled, one camera aimed between them. A grasp picks when it lifts and holds the object
it closes on, the other beside it in every trial.

Runs (the same views, each candidate's outcome its own seeded execution, so the runs compare view for view):
- ``default``: the planner as it ships (the view's objects told apart, its first 3 checked) beside a random
  collision-free candidate, the antipodal score and top-down on the largest object;
- ``unchecked``: the network's order alone (check_first=0);
- ``as_one``: the planner that takes the whole cloud for one object (objects_apart=False), and top-down on it.

    .venv/bin/python -m benchmarks.experiments.pick_pairs

Results: benchmarks/results/pick_pairs.json, rendered into docs/picks.md.
"""

from __future__ import annotations

import json
import platform
import time
from datetime import date

import numpy as np

from benchmarks.experiments.pick_curve import HERE, ROOT

RESULTS = HERE / "results" / "pick_pairs.json"
VIEWS, ATTEMPTS = 8, 3
RUNS = {"default": ({}, ("network", "random", "analytic", "top_down")),
        "unchecked": ({"check_first": 0}, ("network",)),
        "as_one": ({"objects_apart": False}, ("network", "top_down"))}


def _spec(name: str, objects: str, run: str):
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    plan, methods = RUNS[run]
    return PickSpec(objects=objects, checkpoint=str(shipped_network()), pairs=True,
                    output=str(ROOT / "data" / "pick_pairs" / name), views=VIEWS, attempts=ATTEMPTS, pictures=0,
                    methods=methods, plan=PlanSpec(**plan), workers=2)


def measure(name: str, objects: str, run: str) -> dict:
    """One set's pairs in one run (the benchmark's own, `onepiece pick --pairs`, on the embedded Ray): its
    summary over pairs and each pair's first picks per method."""
    from onepiece_dist.picks.runner import run_picks

    spec = _spec(name, objects, run)
    start = time.perf_counter()
    report = run_picks(spec)
    return {"methods": {m.method: {"first_attempt": m.first_attempt, "interval": list(m.first_attempt_interval),
                                   "within_3": m.within_k, "views": m.views, "failures": m.first_failures}
                        for m in report.methods},
            "per_pair": {m: report.first_picks(m) for m in spec.methods},
            "rejected": {p.name: p.reason for p in report.objects if p.status != "ok"},
            "verdict": report.verdict, "seconds": round(time.perf_counter() - start, 1)}


def paired(result: dict, run: str, method: str, base: str, base_method: str = "network") -> dict:
    """``run``'s ``method`` against ``base``'s ``base_method`` on the same views, first attempt, paired over pairs
    (each set and both pooled): the mean difference and its 95% bootstrap interval."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    per_set = {}
    for name, runs in result["sets"].items():
        tried, against = runs[run]["per_pair"][method], runs[base]["per_pair"][base_method]
        per_set[name] = [(tried[p] - against[p]) / VIEWS for p in sorted(set(tried) & set(against))]
    per_set["all pairs"] = [d for diffs in list(per_set.values()) for d in diffs]
    return {name: {"mean": float(np.mean(d)) if d else 0.0, "interval": list(bootstrap_interval(np.array(d)))}
            for name, d in per_set.items()}


def single_rates() -> dict:
    """Per set and method, the one-object benchmark's first attempt on the same objects (committed picks.json)."""
    committed = json.loads((HERE / "results" / "picks.json").read_text())
    return {s["name"]: {m["method"]: m["first_attempt"] for m in s["methods"]} for s in committed["sets"]}


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    result = {"command": ".venv/bin/python -m benchmarks.experiments.pick_pairs", "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "views": VIEWS,
              "attempts": ATTEMPTS, "runs": {run: {"plan": plan, "methods": list(methods)}
                                             for run, (plan, methods) in RUNS.items()},
              "sets": {name: {run: measure(name, objects, run) for run in RUNS} for name, objects in sets.items()}}
    result["single"] = single_rates()
    result["checked_vs_unchecked"] = paired(result, "default", "network", "unchecked")
    result["apart_vs_as_one"] = paired(result, "default", "network", "as_one")
    result["network_vs_top_down"] = paired(result, "default", "network", "default", "top_down")
    RESULTS.write_text(json.dumps(result, indent=1) + "\n")
    print({name: {run: {m: round(v["first_attempt"], 3) for m, v in r["methods"].items()} for run, r in runs.items()}
           for name, runs in result["sets"].items()})


if __name__ == "__main__":
    main()
