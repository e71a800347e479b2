"""The Franka hand's network labelled before the worlds' solver iterations grew with the grip (sim.world.physics_for),
judged by picks at the grip's iterations: is the network of the labels made again at those iterations better than
the one it replaces, judged alike? The network chooser alone, on the pick benchmark's three sets, as pick_panda
judges (8 views an object, the first 3 grasps checked).

    .venv/bin/python -m benchmarks.experiments.pick_panda_then

The network: data/pick_curve/panda_50_iterations/panda_s0/best.pt (pick_panda's seed-0 network from the labels
made at 50 iterations, pick_panda_50_iterations.json, kept there when they were made again). Results:
benchmarks/results/pick_panda_then.json, rendered on docs/picks.md.
"""

from __future__ import annotations

import json
import platform
from datetime import date

from benchmarks.experiments.pick_clutter import hand_record
from benchmarks.experiments.pick_curve import HERE, OUT, ROOT

RESULTS = HERE / "results" / "pick_panda_then.json"
CHECKPOINT = OUT / "panda_50_iterations" / "panda_s0" / "best.pt"


def main() -> None:
    from benchmarks.experiments.picks import run_set, sets

    if not CHECKPOINT.is_file():
        raise SystemExit(f"{CHECKPOINT}: the network labelled at 50 iterations is not on this machine")
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_panda_then", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", **hand_record("panda"),
           "checkpoint": str(CHECKPOINT.relative_to(ROOT)), "sets": []}
    for name, (objects, source) in sets().items():
        out["sets"].append(run_set(name, objects(), source, CHECKPOINT, ROOT / "data" / "pick_panda_then",
                                   ("network",)))
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")
        print(name, out["sets"][-1]["methods"][0]["first_attempt"], flush=True)


if __name__ == "__main__":
    main()
