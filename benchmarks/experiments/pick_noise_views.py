"""The planner under a depth camera's noise judged on more views (docs/picks.md): a change to the planner's
``denoise`` moves every later draw of a view, so 8 views an object (pick_depth_noise) cannot tell a few points
from the reshuffle. The household and unseen sets at VIEWS views an object, the Franka hand with the network
shipped for it (the hand noise costs most), network and top-down, at each of NOISES; each run is kept under a
``--variant`` name with the commit it ran at, and the variants are paired over the 28 meshes.

    .venv/bin/python -m benchmarks.experiments.pick_noise_views --variant NAME [--noises 0.002,0.004]

Results: benchmarks/results/pick_noise_views.json (a variant run again replaces its own runs), rendered into
docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
from datetime import date

from benchmarks.experiments.pick_clutter import hand_record, shipped_for
from benchmarks.experiments.pick_curve import HERE, ROOT

RESULTS = HERE / "results" / "pick_noise_views.json"
VIEWS, NOISES, GRIPPER = 24, (0.004, 0.002), "panda"
SETS, METHODS = ("household", "unseen"), ("network", "top_down")


def judged(variant: str, noise: float) -> list[dict]:
    """Both sets at ``noise`` (m) with today's planner: their pick reports."""
    from benchmarks.experiments.picks import ATTEMPTS, sets
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import CameraSpec, PickSpec

    out = []
    for name in SETS:
        objects, _ = sets()[name]
        network, hand = shipped_for(GRIPPER)
        spec = PickSpec(objects=objects(), checkpoint=str(network), gripper=hand, views=VIEWS, attempts=ATTEMPTS,
                        pictures=0, methods=METHODS, camera=CameraSpec(depth_noise=noise),
                        output=str(ROOT / "data" / "pick_noise_views" / variant / f"{noise:g}" / name))
        out.append({**run_picks(spec).to_json(), "name": name})
        print(variant, noise, name, {m["method"]: m["first_attempt"] for m in out[-1]["methods"]}, flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", required=True, help="the name this run's planner is kept under")
    parser.add_argument("--noises", default=",".join(f"{n:g}" for n in NOISES))
    args = parser.parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT,
                            check=False).stdout.strip()
    runs = json.loads(RESULTS.read_text())["runs"] if RESULTS.is_file() else []
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_noise_views", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", **hand_record(GRIPPER),
           "views": VIEWS, "runs": runs}
    for noise in (float(n) for n in args.noises.split(",")):
        run = {"variant": args.variant, "commit": commit, "noise": noise, "sets": judged(args.variant, noise)}
        out["runs"] = [*[r for r in out["runs"] if (r["variant"], r["noise"]) != (args.variant, noise)], run]
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
