"""Clearing the table (docs/picks.md): VGN's declutter protocol on scenes of 4 household objects
(onepiece_dist/picks/clearance.py). Each object of the household and unseen sets with the next 3 of its set
(wrapping round), settled as `onepiece pick --clutter 4` settles them, VIEWS seeded settles a scene; round after
round a new camera sees what is left, the chooser's first grasp is executed, a picked object leaves; two failed
rounds in a row end it. Per chooser: the share of objects cleared (declutter rate) and of rounds that picked
(grasp success rate), each over scenes with a 95% bootstrap interval.

    .venv/bin/python -m benchmarks.experiments.pick_clearance [--gripper panda] [--pile]

Results: benchmarks/results/pick_clearance.json, rendered into docs/picks.md; with --gripper panda (the network
shipped for the Franka hand planning, every grasp executed by that hand) pick_clearance_panda.json; with --pile
(the objects piled as `onepiece pick --pile` piles them; what is left settles again after each pick)
pick_clearance_pile.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date
from multiprocessing import get_context

import numpy as np

from benchmarks.experiments.pick_clutter import hand_record
from benchmarks.experiments.pick_curve import HERE, ROOT

RESULTS = HERE / "results" / "pick_clearance.json"
SIZE, VIEWS = 4, 4
METHODS = ("network", "random", "analytic", "top_down")


def _spec(name: str, objects: str, gripper: str | None = None, pile: bool = False):
    from benchmarks.experiments.pick_clutter import scene_folder, shipped_for
    from onepiece_dist.specs.plan import PickSpec

    network, hand = shipped_for(gripper)
    return PickSpec(objects=objects, checkpoint=str(network), gripper=hand, clutter=SIZE, views=VIEWS, pictures=0,
                    output=str(ROOT / "data" / scene_folder(gripper, pile) / name), methods=METHODS, pile=pile)


def _scene(task):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clearance import clear_scenes
    from onepiece_dist.picks.clutter import groups_of

    spec, index = task
    return clear_scenes(spec, groups_of(resolve_source(spec.objects), spec.clutter)[index], index)


def measure(name: str, objects: str, processes: int = 2, gripper: str | None = None, pile: bool = False) -> dict:
    """Each scene of one set cleared by each chooser (``gripper``: a preset, its shipped network planning;
    ``pile``: the objects piled): per scene and method, objects cleared, objects, rounds."""
    from onepiece_dist.objects import resolve_source

    spec = _spec(name, objects, gripper, pile)
    start = time.perf_counter()
    with get_context("spawn").Pool(processes) as pool:
        found = sorted(pool.imap_unordered(_scene, [(spec, i) for i in range(len(resolve_source(objects)))]),
                       key=lambda s: s.index)
    scenes = {s.name: {m: {"cleared": sum(v.cleared(m) for v in s.views), "objects": sum(v.objects for v in s.views),
                           "rounds": sum(len(v.rounds[m]) for v in s.views)} for m in METHODS}
              for s in found if s.status == "ok"}
    return {"scenes": scenes, "rejected": {s.name: s.reason for s in found if s.status != "ok"},
            "seconds": round(time.perf_counter() - start, 1)}


def rates(scenes: dict, method: str) -> dict:
    """``method``'s declutter rate (objects cleared of objects) and grasp success rate (rounds that picked of
    rounds), the means of per-scene rates with 95% bootstrap intervals over scenes."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    out = {}
    for key, over in (("declutter", "objects"), ("success", "rounds")):
        per = np.array([s[method]["cleared"] / max(s[method][over], 1) for s in scenes.values()])
        out[key] = {"rate": float(per.mean()) if len(per) else 0.0, "interval": list(bootstrap_interval(per))}
    return out


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gripper", choices=("panda",), default=None,
                        help="the preset whose shipped network plans and whose hand executes")
    parser.add_argument("--pile", action="store_true", help="the objects piled (onepiece pick --pile)")
    args = parser.parse_args()
    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    measured = {name: measure(name, objects, gripper=args.gripper, pile=args.pile) for name, objects in sets.items()}
    every = {f"{name}/{scene}": r for name, m in measured.items() for scene, r in m["scenes"].items()}
    command = (".venv/bin/python -m benchmarks.experiments.pick_clearance" + (f" --gripper {args.gripper}"
                                                                               if args.gripper else "")
               + (" --pile" if args.pile else ""))
    result = {"command": command, "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "objects": SIZE, "views": VIEWS,
              **hand_record(args.gripper), **({"pile": True} if args.pile else {}), "methods": list(METHODS),
              "sets": measured,
              "rates": {**{name: {m: rates(s["scenes"], m) for m in METHODS} for name, s in measured.items()},
                        "all scenes": {m: rates(every, m) for m in METHODS}}}
    path = HERE / "results" / ("pick_clearance" + (f"_{args.gripper}" if args.gripper else "")
                               + ("_pile" if args.pile else "") + ".json")
    path.write_text(json.dumps(result, indent=1) + "\n")
    print({name: {m: round(r["declutter"]["rate"], 3) for m, r in by.items()} for name, by in result["rates"].items()})


if __name__ == "__main__":
    main()
