"""The planner dropping flying pixels (docs/picks.md): at 24 views an object the Franka hand's network is shown to
lose picks to a depth camera's flying pixels (pick_flying_pixels). PlanSpec.veils ``drop`` takes out of the view
each point off the support plane whose local surface runs along its ray (core.cloud.veils). The household and
unseen sets judged at VIEWS views an object with the Franka hand and the network shipped for it, network and
top-down, at each flying share (1: every edge pixel mixed; 0: exact depth), each paired over the 28 meshes against
the planner keeping every point on the same views: pick_flying_pixels' runs at VIEWS views (its share-1 run, and
its micrometre level, read from its folder under data/: run `pick_flying_pixels --gripper panda --views 24` first).

    .venv/bin/python -m benchmarks.experiments.pick_veils [--shares 1,0]

Results: benchmarks/results/pick_veils.json (a share run again replaces its own run), rendered into docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
from datetime import date

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_depth_noise import BASELINE, METHODS, SETS, level
from benchmarks.experiments.pick_flying_pixels import RESULTS as FLYING
from benchmarks.experiments.pick_flying_pixels import views_of
from benchmarks.experiments.pick_panda_check import slim
from benchmarks.pages.pick_sets import paired_first_attempts

RESULTS = HERE / "results" / "pick_veils.json"
VIEWS, GRIPPER, SHARES = 24, "panda", (1.0, 0.0)


def kept_sets(share: float) -> list[dict]:
    """The planner keeping every point on the same views at ``share``: pick_flying_pixels' committed run, or at
    0 its micrometre level's reports (picks.json) under data/."""
    if share:
        runs = json.loads(FLYING.read_text())["runs"]
        return next(r["sets"] for r in runs if (r["gripper"], r["flying"], views_of(r)) == (GRIPPER, share, VIEWS))
    folder = ROOT / "data" / "pick_flying_pixels" / GRIPPER / f"exact_{VIEWS}" / f"{BASELINE:g}_auto"
    missing = [name for name in SETS if not (folder / name / "picks.json").is_file()]
    if missing:
        raise SystemExit(f"{folder}: no picks.json for {', '.join(missing)}: run `.venv/bin/python -m "
                         f"benchmarks.experiments.pick_flying_pixels --gripper {GRIPPER} --views {VIEWS}` first")
    return [{**json.loads((folder / name / "picks.json").read_text()), "name": name} for name in SETS]


def judged(share: float) -> dict:
    """Both sets with the veils dropped at ``share``, paired against the planner keeping every point."""
    folder = ROOT / "data" / "pick_veils" / f"{share:g}"
    made = level(BASELINE, "auto", GRIPPER, folder=folder, views=VIEWS, flying_pixels=share, plan={"veils": "drop"})
    kept = kept_sets(share)
    return {"flying": share, "sets": [slim(s) for s in made["sets"]],
            "network_vs_top_down": made["network_vs_top_down"],
            "versus_kept": {m: paired_first_attempts(made["sets"], kept, m) for m in METHODS},
            "kept": {s["name"]: {m["method"]: m["first_attempt"] for m in s["methods"]} for s in kept}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shares", default=",".join(f"{s:g}" for s in SHARES))
    args = parser.parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT,
                            check=False).stdout.strip()
    before = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {}
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_veils", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "gripper": GRIPPER, "views": VIEWS,
           "commit": commit, "runs": before.get("runs", [])}
    for share in (float(s) for s in args.shares.split(",")):
        run = judged(share)
        out["runs"] = sorted([*[r for r in out["runs"] if r["flying"] != share], run], key=lambda r: -r["flying"])
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
