"""The check's ties broken by how far the hull slipped in the fingers (issue 55). The planner's check (PlanSpec
.check_first) executes each of the network's first grasps on the hull the view implies and puts first the one that
held most often, the network's order on ties. On the ranked-draws views most of the share the check loses to the
surest of the first 3 is lost where several of them held equally often on the hull. Each execution that held
also says how far the hull moved in the fingers while lifted and shaken (sim.trials.lift_and_shake's slip): a
grasp that held with less of it may be the surer one on the true object. This measures that rule, fixed before
it was run: among the grasps that held most often on the hull, the one whose executions that held slipped least
(their mean) goes first; the network's order where that ties too.

The ranked-draws views as pick_shape_check's measure has them (the shipped network's first 5, the hull's check at
the protocol's noise, 8 draws each, the benchmark's own streams), with each execution's slip recorded. The hull's
shares are checked against the ones that measure kept, and each rule is judged by the share of 8 draws on the true
object of the grasp it puts first, paired over objects against the check without the tie-break.

    .venv/bin/python -m benchmarks.experiments.pick_check_slip

Results: benchmarks/results/pick_shape_check.json (``expected_slip``), rendered into docs/picks.md.
"""

from __future__ import annotations

import json

import numpy as np

from benchmarks.experiments.pick_shape_check import (
    DRAWS,
    LOOKED_AT,
    RESULTS,
    _beside,
    _drawn_set,
    _drawn_sets,
    _first_of,
    drawn_summary,
    shape_difference,
    stored_agree,
)

SLIP_CAP_MM = 1000.0  # the key of a grasp that never held: after every grasp that did
SHARE_WEIGHT = 1e4  # the key's share term: one draw's share (1/8) outweighs any slip in mm


def _recorded_set(task) -> tuple[str, list[dict]]:
    """pick_shape_check's _drawn_set of one set on the hull, each grasp's executions' slips (mm, those that held)
    recorded beside its shares (``slips_hull``), in this (spawned) process."""
    from onepiece_dist.picks import shape_check
    from onepiece_dist.sim import pick

    executions: list[tuple[bool, float]] = []  # every lift and shake this process runs: held, slip (m)
    per_pose: list[list[tuple[bool, float]]] = []  # those of each grasp checked, in order
    lift, draws_of = pick.lift_and_shake, shape_check.shape_draws

    def recording_lift(world, start, lost_at=None):
        held, slip = lift(world, start, lost_at)
        executions.append((held, slip))
        return held, slip

    def recording_draws(*args, **kwargs):
        held = draws_of(*args, **kwargs)
        if held is None:
            return None

        def each(pose, settled=None):
            start = len(executions)
            outcomes = held(pose, settled)
            per_pose.append(executions[start:])
            return outcomes

        return each

    pick.lift_and_shake, shape_check.shape_draws = recording_lift, recording_draws
    which, rows = _drawn_set(task)
    poses = iter(per_pose)
    for row in rows:
        row["slips_hull"] = None if row["held_hull"] is None else [
            [round(1000 * slip, 3) for held, slip in next(poses) if held] for _ in range(LOOKED_AT)]
    return which, rows


def slip_key(shares: list[float], slips: list[list[float]]) -> list[float]:
    """A number per grasp whose largest, first on ties, is the rule's first: the share that held on the hull,
    then the least mean slip (mm) of the executions that held."""
    return [SHARE_WEIGHT * share - (float(np.mean(s)) if s else SLIP_CAP_MM)
            for share, s in zip(shares, slips, strict=True)]


def slip_summary(found: list[tuple[str, list[dict]]], stored: dict) -> dict:
    """Per number checked and set (and all objects): drawn_summary of the check with the tie-break and its first
    against the check's, paired over objects; how many views' hull shares equal the kept ones; the views where
    the tie-break changed the first."""
    rows = {which: [{**row, "held_slip": None if row["held_hull"] is None
                     else slip_key(row["held_hull"], row["slips_hull"])} for row in set_rows]
            for which, set_rows in found}
    out = {"stored_agree": stored_agree(rows, stored)}
    rows["all objects"] = [row for set_rows in list(rows.values()) for row in set_rows]
    for k in (3, LOOKED_AT):
        out[str(k)] = {which: {**drawn_summary(set_rows, k, "slip"),
                               "versus": shape_difference(set_rows, k, "hull", "slip"),
                               "changed": sum(_first_of(r["held_slip"], k) != _first_of(r["held_hull"], k)
                                              for r in set_rows if r["held_hull"] is not None)}
                       for which, set_rows in rows.items()}
    out["rows"] = {which: [{"object": r["object"], "shares": r["shares"], "held_hull": r["held_hull"],
                            "slips_hull": r["slips_hull"]} for r in set_rows] for which, set_rows in found}
    return out


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    stored = json.loads(RESULTS.read_text())["expected_shapes"]["rows"]["carved"]
    found = _drawn_sets(sets, 1.0, ("hull",), DRAWS, run=_recorded_set)
    summary = slip_summary(found, stored)
    _beside(lambda result: result.update(expected_slip=summary))
    print(json.dumps({k: v for k, v in summary.items() if k != "rows"}, indent=1))


if __name__ == "__main__":
    main()
