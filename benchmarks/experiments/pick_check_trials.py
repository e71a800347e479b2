"""The planner's check drawn by single trials (issue 55; planning with the check took 0.378 s a view against 0.3 s).
The check executes each of the network's first 3 grasps ``check_draws`` = 4 times by the whole pick protocol (the
nominal trial, then perturbed ones until one fails), on the shape the view implies. The nominal trial is the same at
every draw (so it is executed once: shape_check.protocol_draws), and a draw's perturbed trials tell apart only
whether all of them held. Drawn by single trials, the check executes the nominal trial once (a grasp whose nominal
trial fails cannot pick) and then n perturbed trials, and orders the grasps by how many of those held. On the
ranked-draws views (pick_ranked_draws: the shipped network's first grasps, each executed 8 times on the object
itself) both checks are run on the same hull, and each is judged by the share of 8 draws of the grasp it puts first,
paired over objects; the seconds are what each check would execute with the planner's lazy order
(shape_check.lazy_order: it stops where the first held every draw).

    .venv/bin/python -m benchmarks.experiments.pick_check_trials

Results: benchmarks/results/pick_check_trials.json.
"""

from __future__ import annotations

import json
import platform
import time
from datetime import date

import numpy as np

from benchmarks.experiments.pick_curve import HERE
from benchmarks.experiments.pick_ranked_draws import RESULTS as RANKED
from benchmarks.experiments.pick_ranked_draws import seen_again

RESULTS = HERE / "results" / "pick_check_trials.json"
CHECKED, DRAWS, TRIALS = 3, 4, 16  # grasps checked; the planner's draws; the most single trials measured
COUNTS = (0, 1, 2, 4, 6, 8, 12, 16)  # the perturbed trials each judged (the first of one run; 0: the nominal alone)


def _timed(execute, *args, **kwargs) -> tuple[object, float]:
    clock = time.perf_counter()
    outcome = execute(*args, **kwargs)
    return outcome, round(time.perf_counter() - clock, 4)


def _view_checks(world, shape, poses, noise, sim_seed) -> dict:
    """Both checks of ``poses`` on ``shape`` loaded on ``world``: each protocol draw's success and seconds; each
    grasp's nominal trial, then (where it held) TRIALS perturbed ones, their outcomes and seconds."""
    from onepiece_dist.core.frames import compose_poses
    from onepiece_dist.picks.shape_check import protocol_draws
    from onepiece_dist.sim.pick import execute_trial

    rest = np.eye(4)
    protocol_rng, trial_rng = np.random.default_rng(sim_seed), np.random.default_rng([*sim_seed, TRIALS])
    protocol, trials = [], []
    for pose in poses:
        placed = compose_poses(shape.to_plane, pose)
        held, seconds = _timed(protocol_draws, world, placed, rest, noise, protocol_rng, DRAWS)
        protocol.append({"held": [bool(h) for h in held], "seconds": seconds})
        nominal, seconds = _timed(execute_trial, world, placed, rest, noise, trial_rng, perturbed=False)
        perturbed = ([_timed(execute_trial, world, placed, rest, noise, trial_rng, perturbed=True)
                      for _ in range(TRIALS)] if nominal == "" else [])
        trials.append({"nominal": nominal == "", "held": [o == "" for o, _ in perturbed],
                       "seconds": [seconds, *(s for _, s in perturbed)]})
    return {"protocol": protocol, "trials": trials}


def _drawn_set(task) -> tuple[str, list[dict]]:
    """The ranked-draws views of one set seen again, both checks run on each view's hull."""
    import torch

    from benchmarks.experiments.pick_shape_check import _spec
    from onepiece_dist.picks.object_picks import process_scorer
    from onepiece_dist.picks.shape_check import check_shape, check_world
    from onepiece_dist.plan.planner import Seen
    from onepiece_dist.sim.trials import LabelNoise

    which, objects, stored = task
    torch.set_num_threads(1)
    spec = _spec(objects, CHECKED)
    scorer = process_scorer(spec)
    noise, rows = LabelNoise.from_spec(spec.sim), []
    for again in seen_again(spec, scorer, objects, stored, CHECKED, []):
        seen = Seen.of(again.seen.proposals)
        shape = check_shape(seen, "hull")
        if shape is None:
            continue
        world = check_world(scorer.gripper)
        world.load_object(list(shape.pieces), shape.volume, spec.sim.density)
        poses = again.seen.proposals.poses[again.chosen]
        rows.append({"object": again.ref.name, "shares": np.mean(again.stored["draws"], axis=1)[:CHECKED].tolist(),
                     **_view_checks(world, shape, poses, noise, tuple(again.seen.check_seed))})
    return which, rows


def protocol_shares(row: dict, draws: int = DRAWS) -> list[float]:
    return [sum(g["held"][:draws]) / draws for g in row["protocol"]]


def trial_shares(row: dict, n: int) -> list[float]:
    """Each grasp's share of its first ``n`` perturbed trials that held; -1 where its nominal trial failed."""
    return [sum(g["held"][:n]) / max(n, 1) if g["nominal"] else -1.0 for g in row["trials"]]


def protocol_seconds(row: dict) -> float:
    """What the planner's lazy check (shape_check.lazy_order) would execute of the protocol draws
    (shape_check.protocol_draws: the nominal trial once, each draw's perturbed trials until one fails): stop after
    the first grasp where it held every draw."""
    grasps = row["protocol"]
    return grasps[0]["seconds"] if all(grasps[0]["held"]) else sum(g["seconds"] for g in grasps)


def trial_seconds(row: dict, n: int) -> float:
    """The same for the single-trial check with ``n`` perturbed trials a grasp: the first grasp's alone where all of
    them held."""
    grasps = row["trials"]
    cost = [g["seconds"][0] + sum(g["seconds"][1:n + 1]) for g in grasps]
    first = grasps[0]
    return cost[0] if first["nominal"] and all(first["held"][:n]) else sum(cost)


def _paired_gain(rows: list[dict], first_of, base_of) -> tuple[float, list[float]]:
    """The share of 8 draws of the grasp ``first_of(row)`` names less that of ``base_of(row)``'s, paired over
    objects: the mean and its 95% bootstrap interval."""
    from onepiece_dist.stats.intervals import bootstrap_interval

    gain = {}
    for row in rows:
        gain.setdefault(row["object"], []).append(row["shares"][first_of(row)] - row["shares"][base_of(row)])
    per_object = np.array([np.mean(v) for _, v in sorted(gain.items())])
    return float(per_object.mean()), list(bootstrap_interval(per_object))


def _first(shares_of):
    """Which grasp the check ``shares_of`` puts first (the network's order on ties)."""
    return lambda row: int(np.argmax(shares_of(row)))


def summary(rows: list[dict], shares_of) -> dict:
    """The share of 8 draws of the grasp the check puts first (the network's order on ties) against the network's
    first, paired over objects."""
    gain, interval = _paired_gain(rows, _first(shares_of), lambda row: 0)
    return {"checked": float(np.mean([row["shares"][_first(shares_of)(row)] for row in rows])), "gain": gain,
            "interval": interval}


def versus(rows: list[dict], shares_of, base_of) -> dict:
    """The check ``shares_of``'s first against ``base_of``'s, by shares of 8 draws, paired over objects."""
    mean, interval = _paired_gain(rows, _first(shares_of), _first(base_of))
    return {"mean": mean, "interval": interval}


def measured(rows: list[dict]) -> dict:
    out = {"views": len(rows), "first": float(np.mean([r["shares"][0] for r in rows])),
           "surest": float(np.mean([max(r["shares"]) for r in rows])),
           "protocol": {**summary(rows, protocol_shares),
                        "seconds_a_view": float(np.mean([protocol_seconds(r) for r in rows]))}}
    for n in COUNTS:
        out[f"trials_{n}"] = {**summary(rows, lambda r, n=n: trial_shares(r, n)),
                              "seconds_a_view": float(np.mean([trial_seconds(r, n) for r in rows])),
                              "versus_protocol": versus(rows, lambda r, n=n: trial_shares(r, n), protocol_shares)}
    return out


def main() -> None:
    from multiprocessing import get_context

    from benchmarks.experiments.household import UNSEEN, household_objects

    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    ranked = json.loads(RANKED.read_text())
    start = time.perf_counter()
    with get_context("spawn").Pool(2) as pool:
        found = dict(pool.map(_drawn_set, [(w, o, ranked["sets"][w]["rows"]) for w, o in sets.items()]))
    found["all objects"] = [row for rows in list(found.values()) for row in rows]
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_check_trials", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "checked": CHECKED, "draws": DRAWS,
           "counts": list(COUNTS), "seconds": round(time.perf_counter() - start, 1),
           "sets": {which: measured(rows) for which, rows in found.items()},
           "rows": {w: rows for w, rows in found.items() if w != "all objects"}}
    RESULTS.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({w: {k: v for k, v in m.items()} for w, m in out["sets"].items()}, indent=1))


if __name__ == "__main__":
    main()
