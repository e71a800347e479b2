"""The planner under a depth camera's noise judged on more views (docs/picks.md): a change to the planner's
``denoise`` moves every later draw of a view, so 8 views an object (pick_depth_noise) cannot tell a few points
from the reshuffle. The household and unseen sets at VIEWS views an object, the Franka hand with the network
shipped for it (the hand noise costs most), network and top-down, at each of NOISES; each run is kept under a
``--variant`` name with the commit it ran at, and paired over the 28 meshes against the variant it changes
(``--against``, by default the first run).

    .venv/bin/python -m benchmarks.experiments.pick_noise_views --variant NAME [--what WORDS] [--against NAME]
        [--noises 0.002,0.004]

Results: benchmarks/results/pick_noise_views.json (a variant run again replaces its own runs), rendered into
docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
from datetime import date

from benchmarks.experiments.pick_clutter import hand_record
from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_depth_noise import level
from benchmarks.experiments.pick_panda_check import slim

RESULTS = HERE / "results" / "pick_noise_views.json"
VIEWS, NOISES, GRIPPER = 24, (0.004, 0.002), "panda"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", required=True, help="the name this run's planner is kept under")
    parser.add_argument("--what", default="", help="what this variant's planner does (the page's legend)")
    parser.add_argument("--against", default="", help="the variant this one changes (default: the first run)")
    parser.add_argument("--noises", default=",".join(f"{n:g}" for n in NOISES))
    args = parser.parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT,
                            check=False).stdout.strip()
    before = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {}
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_noise_views", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", **hand_record(GRIPPER),
           "views": VIEWS, "runs": before.get("runs", []),
           "variants": {**before.get("variants", {}), **({args.variant: args.what} if args.what else {})}}
    for noise in (float(n) for n in args.noises.split(",")):
        judged = level(noise, "auto", GRIPPER, folder=ROOT / "data" / "pick_noise_views" / args.variant, views=VIEWS)
        run = {"variant": args.variant, "commit": commit, "noise": noise, "sets": [slim(s) for s in judged["sets"]],
               **({"against": args.against} if args.against else {})}
        out["runs"] = [*[r for r in out["runs"] if (r["variant"], r["noise"]) != (args.variant, noise)], run]
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
