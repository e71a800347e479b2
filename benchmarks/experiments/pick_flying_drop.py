"""The planner dropping a depth image's flying pixels (docs/picks.md): `onepiece grasp --drop-flying`,
PlanSpec.drop_flying, core.cloud.flying; a pixel that lies inside its neighbours' depths and fits neither
neighbouring surface is dropped before the image is back-projected. The Franka hand with the network shipped for
it, the household and unseen sets as pick_flying_pixels judges them (the micrometre level, the network and
top-down), every edge pixel flying and on exact depth, each tolerance paired over objects against the planner
keeping every pixel on the same views. Views are judged in blocks of 24 (PickSpec.first_view), so more views add
blocks and a block already judged (its reports under data/) is read again, not run; the first block of the
planner keeping every pixel is pick_flying_pixels' 24-view Franka run and its exact level.

    .venv/bin/python -m benchmarks.experiments.pick_flying_drop [--tolerances 0.005,0.01] [--shares 1,0] [--views 48]

Results: benchmarks/results/pick_flying_drop.json, rendered into docs/picks.md; with the first rule tried
(branch image-veils at ba75109, every pixel that fits neither continuation; its reports under data/) where they
are on this machine.
"""

from __future__ import annotations

import argparse
import functools
import json
import platform
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_depth_noise import BASELINE, METHODS, SETS, level
from benchmarks.pages.pick_sets import first_attempt_share, loaded_objects, paired_first_attempts, pooled

RESULTS = HERE / "results" / "pick_flying_drop.json"
BLOCK, GRIPPER, SHARES = 24, "panda", (1.0, 0.0)
KEPT = {1.0: ROOT / "data" / "pick_flying_pixels" / GRIPPER / "1" / "24",  # the planner keeping every pixel
        0.0: ROOT / "data" / "pick_flying_pixels" / GRIPPER / "exact_24"}
FIRST_RULE = ("ba75109", ROOT / "data" / "pick_image_veils")  # the rule first tried, on the image-veils branch


@functools.cache
def block(tolerance: float, share: float, first: int) -> list[dict]:
    """Both sets' reports of views ``first`` to ``first + BLOCK - 1`` with ``share`` of the edge pixels flying and
    the planner dropping flying pixels at ``tolerance`` (0: keeping every pixel): read where judged, else run."""
    folder = KEPT[share] if (tolerance, first) == (0.0, 0) else (
        ROOT / "data" / "pick_flying_drop" / f"{tolerance:g}" / f"{share:g}" / f"from_{first}")
    reports = [folder / f"{BASELINE:g}_auto" / name / "picks.json" for name in SETS]
    if not all(path.is_file() for path in reports):
        level(BASELINE, "auto", GRIPPER, folder=folder, views=BLOCK, flying_pixels=share, drop_flying=tolerance,
              first_view=first)
    return [{**json.loads(path.read_text()), "name": name} for path, name in zip(reports, SETS, strict=True)]


def joined(blocks: list[list[dict]]) -> list[dict]:
    """Each set's reports of consecutive view blocks as one: each object's views in order."""
    sets = []
    for parts in zip(*blocks, strict=True):  # one set's report in each block
        objects = []
        for same in zip(*(part["objects"] for part in parts), strict=True):  # one object in each block
            status = next((o["status"] for o in same if o["status"] != "ok"), "ok")
            objects.append({**same[0], "status": status, "views": [v for o in same for v in o.get("views", [])]})
        sets.append({**parts[0], "objects": objects})
    return sets


def judged(tolerance: float, share: float, views: int) -> dict:
    """``tolerance`` at ``share`` over ``views`` views an object, paired against keeping every pixel."""
    made = joined([block(tolerance, share, first) for first in range(0, views, BLOCK)])
    kept = joined([block(0.0, share, first) for first in range(0, views, BLOCK)])
    return {"tolerance": tolerance, "flying": share, "views": views, "objects": first_attempts(made),
            "pooled": {m: pooled(made, m) for m in METHODS}, "kept_pooled": {m: pooled(kept, m) for m in METHODS},
            "versus_kept": {m: paired_first_attempts(made, kept, m) for m in METHODS}}


def first_attempts(sets: list[dict]) -> dict:
    """Per loaded object ("set/name"): each chooser's share of its views picked at the first attempt (what a
    pairing reads; the views themselves stay in the reports under data/)."""
    return {f"{s['name']}/{o['name']}": {m: first_attempt_share(o, m) for m in METHODS}
            for s, o in loaded_objects(sets)}


def first_rule() -> list[dict]:
    """The rule first tried (FIRST_RULE), at the 24 views it was judged at, where its reports are here."""
    commit, folder = FIRST_RULE
    runs = []
    for share in SHARES:
        paths = [folder / f"{share:g}" / name / "picks.json" for name in SETS]
        if all(path.is_file() for path in paths):
            made = [{**json.loads(p.read_text()), "name": n} for p, n in zip(paths, SETS, strict=True)]
            kept = block(0.0, share, 0)
            runs.append({"commit": commit, "flying": share, "views": BLOCK,
                         "pooled": {m: pooled(made, m) for m in METHODS},
                         "versus_kept": {m: paired_first_attempts(made, kept, m) for m in METHODS}})
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolerances", default="0.005,0.01", help="Comma-separated tolerances (m).")
    parser.add_argument("--shares", default=",".join(f"{s:g}" for s in SHARES),
                        help="Comma-separated flying shares (1: every edge pixel).")
    parser.add_argument("--views", type=int, default=BLOCK, help=f"Views an object, a multiple of {BLOCK}.")
    args = parser.parse_args()
    runs = json.loads(RESULTS.read_text())["runs"] if RESULTS.is_file() else []
    for tolerance in (float(t) for t in args.tolerances.split(",")):
        for share in (float(f) for f in args.shares.split(",")):
            run = judged(tolerance, share, args.views)
            runs = [r for r in runs if (r["tolerance"], r["flying"], r["views"]) != (tolerance, share, args.views)]
            runs.append(run)
            print(tolerance, share, args.views, {m: round(100 * v["mean"], 1) for m, v in run["versus_kept"].items()},
                  flush=True)
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_flying_drop", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "gripper": GRIPPER, "block": BLOCK,
           "runs": sorted(runs, key=lambda r: (r["tolerance"], -r["flying"], r["views"])), "first_rule": first_rule()}
    Path(RESULTS).write_text(json.dumps(out, indent=1) + "\n")
    print(RESULTS)


if __name__ == "__main__":
    main()
