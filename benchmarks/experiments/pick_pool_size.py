"""More candidates per view for the shipped network to rank (docs/picks.md, "Rankings tried"): the network alone,
first attempt, at ``plan.candidates`` 500 (the default), 1,000 and 2,000 placements per view, on the selection set
of unseen procedural objects and on the household set (the same views as the pick benchmark's).

    .venv/bin/python -m benchmarks.experiments.pick_pool_size        # about 12 minutes on 2 cores
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from benchmarks.experiments.pick_rankings import CHECKPOINT, SELECTION

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results" / "pick_pool_size.json"
SIZES = (500, 1000, 2000)


def judge(name: str, objects: str, candidates: int) -> dict:
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec

    spec = PickSpec(objects=objects, checkpoint=str(CHECKPOINT), views=8, attempts=3, pictures=0,
                    output=str(ROOT / "data" / "pick_pool_size" / f"{name}_{candidates}"), methods=("network",),
                    plan={"candidates": candidates, "top_down": False, "check_first": 0})
    start = time.perf_counter()
    network = run_picks(spec).method("network")
    return {"set": name, "candidates": candidates, "first_attempt": round(network.first_attempt, 4),
            "interval": [round(v, 4) for v in network.first_attempt_interval], "views": network.views,
            "failures": network.first_failures, "seconds": round(time.perf_counter() - start, 1)}


def main() -> None:
    from benchmarks.experiments.household import household_objects

    sets = {"selection": SELECTION, "household": str(household_objects())}
    points = [judge(name, objects, n) for name, objects in sets.items() for n in SIZES]
    RESULTS.write_text(json.dumps({"checkpoint": str(CHECKPOINT.relative_to(ROOT)), "points": points}, indent=1)
                       + "\n")
    for p in points:
        print(p["set"], p["candidates"], p["first_attempt"], p["seconds"])


if __name__ == "__main__":
    main()
