"""The pick curve's networks judged on the unseen household set (docs/picks.md, "On objects nothing was chosen
on"): every design, ranking and seed of docs/picks.md was chosen on the household set's 128 views, so a network's
figure there is biased upwards by the choice. The unseen set (benchmarks/experiments/household.py, UNSEEN) judges
the networks the curve and the trials made, the network alone, first attempt; nothing is chosen on it: the shipped
network stays whatever these figures say, and they are reported beside their household figures.

    .venv/bin/python -m benchmarks.experiments.pick_unseen [--networks NAME,...]
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
RESULTS = HERE / "results" / "pick_unseen.json"
OUT = ROOT / "data" / "pick_unseen"
NETWORKS = {  # name -> (checkpoint, what, the results file with its household figure, top-down grasps in its pool)
    "shipped": ("onepiece_dist/plan/networks/pick_view.pt",
                "the shipped network: context_balanced, 81,152 labels, the first batch's executing the top-down "
                "grasps (pick_top_down's seed 0), planning with them in the pool", "picks.json", True),
    "earlier_shipped": ("data/pick_curve/context_balanced_81152/best.pt",
                        "shipped before the top-down trial was kept: context_balanced, 81,152 labels of the earlier "
                        "pick world, seed 0", "pick_curve.json", False),
    "random_s0": ("data/pick_curve/on_policy/random_s0/best.pt",
                  "context_balanced, 81,152 labels (both batches made again, random), seed 0", "pick_on_policy.json",
                  False),
    "random_s1": ("data/pick_curve/on_policy/random_s1/best.pt",
                  "context_balanced, the same labels, seed 1", "pick_on_policy.json", False),
    "on_policy_s0": ("data/pick_curve/on_policy/on_policy_s0/best.pt",
                     "context_balanced, 81,152 labels, the second batch on policy, seed 0", "pick_on_policy.json",
                     False),
    "on_policy_s1": ("data/pick_curve/on_policy/on_policy_s1/best.pt",
                     "context_balanced, the same labels, seed 1", "pick_on_policy.json", False),
}


BASE = "data/pick_curve/on_policy/random_s{seed}/best.pt"  # the first batch and the curve's second, random
DESIGN = "context_balanced"


def judge(name: str, checkpoint: str, objects: str | None = None, top_down: bool = False,
          out: Path = OUT) -> dict:
    """``checkpoint``'s network alone on ``objects`` (default: the unseen set), first attempt; ``top_down``: the
    top-down grasps in its pool (PlanSpec.top_down)."""
    from benchmarks.experiments.household import UNSEEN, household_objects
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    spec = PickSpec(objects=objects or str(household_objects(objects=UNSEEN)), checkpoint=str(ROOT / checkpoint),
                    output=str(out / name), views=8, attempts=3, pictures=0, methods=("network",),
                    plan=PlanSpec(top_down=top_down, check_first=0))
    start = time.perf_counter()
    report = run_picks(spec)
    network = report.method("network")
    return {"first_attempt": network.first_attempt, "interval": list(network.first_attempt_interval),
            "views": network.views, "failures": network.first_failures,
            "per_object": report.first_picks("network"), "seconds": round(time.perf_counter() - start, 1)}


def base_point(seed: int) -> dict:
    """The trials' base network at ``seed`` (DESIGN on the first batch and the curve's second, random): the
    on-policy trial's random point and its unseen figure where committed, else fitted and judged here."""
    from benchmarks.experiments.household import household_objects
    from benchmarks.experiments.pick_curve import fit, labels
    from benchmarks.experiments.pick_on_policy import second_batch

    committed = {p["seed"]: p for p in json.loads((HERE / "results" / "pick_on_policy.json").read_text())["points"]
                 if p["second_batch"] == "random"}
    if seed in committed:
        unseen = json.loads(RESULTS.read_text())["networks"][f"random_s{seed}"]["unseen"]
        return {"checkpoint": BASE.format(seed=seed), "labels": committed[seed]["labels"],
                "household": committed[seed]["picks"]["methods"]["network"]["first_attempt"],
                "unseen": unseen["first_attempt"],
                "per_object": {"household": committed[seed]["picks"]["per_object"]["network"],
                               "unseen": unseen["per_object"]}}
    joined = labels(1).joined(second_batch(None))
    fitted = fit(joined, len(joined), DESIGN, seed, ROOT / BASE.format(seed=seed).rsplit("/", 1)[0])
    name, out = f"random_s{seed}_product", ROOT / "data" / "pick_curve" / "top_down"
    found = {"household": judge(f"{name}_household", fitted["checkpoint"], str(household_objects()), out=out),
             "unseen": judge(f"{name}_unseen", fitted["checkpoint"], out=out)}
    return {"checkpoint": fitted["checkpoint"], "labels": fitted["labels"],
            **{where: j["first_attempt"] for where, j in found.items()},
            "per_object": {where: j["per_object"] for where, j in found.items()}}


def household_figure(name: str) -> float | None:
    """The network's committed first-attempt rate on the household set."""
    checkpoint, _, source, _ = NETWORKS[name]
    committed = json.loads((HERE / "results" / source).read_text())
    if source == "picks.json":
        household = next(s for s in committed["sets"] if s["name"] == "household")
        return next(m["first_attempt"] for m in household["methods"] if m["method"] == "network")
    point = next((p for p in committed["points"] if p["checkpoint"] == checkpoint), None)
    return point["picks"]["methods"]["network"]["first_attempt"] if point else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--networks", default=",".join(NETWORKS))
    names = [n for n in parser.parse_args().networks.split(",") if n]
    done = json.loads(RESULTS.read_text())["networks"] if RESULTS.is_file() else {}
    for name in names:
        checkpoint, what, _, pool = NETWORKS[name]
        done[name] = {"checkpoint": checkpoint, "what": what, "household": household_figure(name),
                      "unseen": judge(name, checkpoint, top_down=pool)}
        print(name, done[name]["household"], done[name]["unseen"]["first_attempt"], flush=True)
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_unseen", "date": date.today().isoformat(),
           "networks": {n: done[n] for n in NETWORKS if n in done}}
    RESULTS.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
