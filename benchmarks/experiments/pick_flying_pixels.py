"""The shipped planner under a depth camera's flying pixels (docs/picks.md): where a pixel straddles an object's
edge, a stereo or time-of-flight camera reads a depth between the object and what lies behind it, so a veil of
points trails off every silhouette into the air. The pick benchmark renders exact depth; here a share of the pixels
at its depth edges (a 4-neighbour 2 cm nearer or further) mix both depths (`onepiece pick` spec
``camera.flying_pixels``, sim.views.mixed_edges). The household and unseen sets judged as the depth-noise benchmark
judges them (pick_depth_noise: 8 views an object, the shipped network and the planner's defaults, beside top-down,
with noise of a micrometre), each share paired over objects against that benchmark's micrometre level: the same
objects, settles and cameras; the mixing's draws come before the noise's, so later draws differ, a difference of
its own of a few points at one draw a view. With ``--views`` other than the pick benchmark's 8, the micrometre
level is judged here at that many views too (kept with the run), so more views can narrow the intervals.

    .venv/bin/python -m benchmarks.experiments.pick_flying_pixels [--shares 1.0] [--gripper panda] [--views 24]

Results: benchmarks/results/pick_flying_pixels.json (a share run again for a hand at as many views replaces its
own run), rendered into docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import date

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_depth_noise import BASELINE, METHODS, level, results_path
from benchmarks.experiments.pick_panda_check import slim
from benchmarks.experiments.picks import VIEWS
from benchmarks.pages.pick_sets import paired_first_attempts

RESULTS = HERE / "results" / "pick_flying_pixels.json"
SHARES = (1.0,)


def micrometre_level(gripper: str | None) -> dict:
    """The depth-noise benchmark's committed micrometre level of ``gripper``'s (``denoise: auto``)."""
    levels = json.loads(results_path(gripper).read_text())["levels"]
    return next(lv for lv in levels if (lv["noise"], lv["denoise"]) == (BASELINE, "auto"))


def exact_level(gripper: str | None, views: int) -> dict:
    """The micrometre level of ``gripper``'s at ``views`` views an object: the depth-noise benchmark's committed one
    at the pick benchmark's views, else judged here."""
    if views == VIEWS:
        return micrometre_level(gripper)
    folder = ROOT / "data" / "pick_flying_pixels" / (gripper or "default") / f"exact_{views}"
    return level(BASELINE, "auto", gripper, folder=folder, views=views)


def judged(share: float, gripper: str | None, views: int = VIEWS) -> dict:
    """Both sets with a ``share`` of the edge pixels flying at ``views`` views an object, paired against the
    micrometre level at as many views."""
    folder = ROOT / "data" / "pick_flying_pixels" / (gripper or "default") / f"{share:g}" / f"{views}"
    base = exact_level(gripper, views)
    made = level(BASELINE, "auto", gripper, folder=folder, views=views, flying_pixels=share)
    return {"gripper": gripper, "flying": share, "views": views, "sets": [slim(s) for s in made["sets"]],
            "network_vs_top_down": made["network_vs_top_down"],
            "versus_exact": {m: paired_first_attempts(made["sets"], base["sets"], m) for m in METHODS},
            "exact": {s["name"]: {m["method"]: m["first_attempt"] for m in s["methods"]} for s in base["sets"]}}


def views_of(run: dict) -> int:
    """The views an object ``run`` was judged at (runs before the option: the pick benchmark's)."""
    return run.get("views", VIEWS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shares", default=",".join(f"{s:g}" for s in SHARES))
    parser.add_argument("--gripper", choices=("panda",), default=None,
                        help="the preset whose shipped network plans and whose hand executes")
    parser.add_argument("--views", type=int, default=VIEWS, help="views an object (the pick benchmark's: 8)")
    args = parser.parse_args()
    before = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {}
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_flying_pixels", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "runs": before.get("runs", [])}
    for share in (float(s) for s in args.shares.split(",")):
        run = judged(share, args.gripper, args.views)
        kept = [r for r in out["runs"] if (r["gripper"], r["flying"], views_of(r)) != (args.gripper, share, args.views)]
        out["runs"] = sorted([*kept, run], key=lambda r: (r["gripper"] or "", r["flying"], views_of(r)))
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
