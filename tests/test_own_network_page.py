"""The own-network section of docs/picks.md: rows say how high over the table their labels were planned, and labels
made at another height are judged against those made at 2 mm on the same objects, seeds and fit."""

from __future__ import annotations

import functools

from benchmarks.pages.pick_own_section import own_network_section
from onepiece_dist.specs.plan import PICK_LABEL_OBJECTS

HOUSEHOLD = [f"h{i}.obj" for i in range(16)]
UNSEEN = [f"u{i}.obj" for i in range(12)]


def picks(household: int, unseen: int) -> dict:
    """Every household object picked at ``household`` of its 8 views, every unseen one at ``unseen``."""
    def one(names: list[str], n: int) -> dict:
        return {"first_attempt": n / 8, "interval": [n / 8, n / 8], "views": 8 * len(names),
                "per_object": dict.fromkeys(names, n)}
    return {"household": one(HOUSEHOLD, household), "unseen": one(UNSEEN, unseen)}


def row(label_seed: int, fit_seed: int, picked: dict, height: float | None, start_from: str | None = None) -> dict:
    made = {"seed": label_seed, "objects": PICK_LABEL_OBJECTS, "views": 8, "per_view": 16,
            "gripper": "onepiece_box", "labels": 8169, "core_seconds": 290.0,
            **({} if height is None else {"table_clearance": height})}
    network = {"fit_seconds": 50.0, "validation": {"top1": 0.9, "guess": 0.4},
               **({} if start_from is None else {"start_from": "onepiece_dist/plan/networks/pick_view.pt"})}
    return {"label_seed": label_seed, "fit_seed": fit_seed, "made": made, "network": network, "picks": picked,
            **({} if start_from is None else {"start_from": start_from})}


@functools.cache
def section(gap_household: int) -> list[str]:
    before = [row(s, f, picks(6, 5), None) for s in (0, 1) for f in (0, 1)]  # stored before the height was kept
    today = [row(s, f, picks(gap_household, 5), 0.008) for s in (0, 1) for f in (0, 1)]
    result = {"networks": [*before, *today], "shipped": picks(7, 6), "command": "cmd", "date": "d", "machine": "m",
              "views": 8}
    return own_network_section(result, 0.85)  # a list: read, never changed


def test_a_row_labelled_8_mm_over_the_table_says_so_and_one_labelled_before_does_not():
    lines = section(7)
    rows = [line for line in lines if line.startswith(f"| `{PICK_LABEL_OBJECTS}`")]
    assert len(rows) == 8
    assert sum("labelled 8 mm over the table" in line for line in rows) == 4
    assert "2 mm over the table, the planner's height then" in lines[2]


def test_labels_made_8_mm_over_the_table_are_judged_against_those_made_at_2_mm_at_the_same_seeds():
    verdicts = [line for line in section(7) if line.startswith("Labelled on") and "8 mm over the table" in line]
    assert len(verdicts) == 1
    against = verdicts[0].split("Against the networks labelled 2 mm over the table on the same objects")[1]
    assert against.startswith(", fitted the same way, at the same seeds, over both sets: +7.1 points")
    assert "): kept" in against  # every household object one view higher, the unseen ones the same
    assert "; on the household set: +12.5 points" in against and "; on the unseen set: +0.0 points" in against
    assert against.endswith(" The planner's options (above) judge such pairs again at 40 views an object.")
    lower = next(line for line in section(5) if line.startswith("Labelled on") and "8 mm over" in line)
    assert "over both sets: -7.1 points" in lower.split("Against the networks labelled 2 mm")[1]
    plain = next(line for line in section(7) if line.startswith("Labelled on") and "8 mm over" not in line)
    assert "Against the networks labelled 2 mm" not in plain  # the 2 mm rows are the base, paired with nothing


def relabelled(household: int, seeds: int = 2) -> dict:
    batch = {"folder": "data/b", "objects": "o", "labels": 40000, "success_rate": 0.3, "top_down": True,
             "table_clearance": 0.008, "core_seconds": 2000.0}
    points = [{"seed": seed, "labels": 80000, "fit_seconds": 600.0, "best_epoch": {"val_ap": 0.8},
               "picks": picks(household, 5)} for seed in range(seeds)]
    return {"command": "cmd", "date": "d", "machine": "m", "design": "context_balanced", "batches": [batch],
            "shipped": picks(6, 5), "points": points}


def test_the_shipped_recipe_labelled_again_replaces_the_shipped_network_only_where_household_picks_rise():
    from benchmarks.pages.pick_relabelled_section import relabelled_section

    higher = relabelled_section(relabelled(7))
    assert "| `data/b` | `o` | 40000 | 30% | yes | 8 mm | 2000 |" in higher
    assert higher[-1].startswith("Against the shipped network on the same views, over both sets: +7.1 points")
    assert "; on the unseen set: +0.0 points" in higher[-1] and higher[-1].endswith(": it does).")
    assert relabelled_section(relabelled(6))[-1].endswith(": the shipped one stays).")
    one_seed = relabelled_section(relabelled(7, seeds=1))[-1]  # one seed decides nothing
    assert one_seed.endswith(": the shipped one stays).")
    assert relabelled_section({**relabelled(7), "points": []}) == []
    versus = {"mean": -0.015, "interval": [-0.029, 0.0]}
    options = {"variants": {"nms_none": {"views": 40, "versus": {}},
                            "relabelled_s0": {"views": 40, "relabelled": 0,
                                              "versus": {"all objects": versus, "household": versus}}}}
    assert relabelled_section(relabelled(7), options)[-1] == (
        "At 40 views an object (the planner's options, above: the `relabelled_` variants), against the shipped "
        "network on the same views and draws: seed 0: -1.5 [-2.9, +0.0] over both sets, household -1.5 [-2.9, +0.0].")
    assert relabelled_section(relabelled(7), {"variants": {}})[-1] == higher[-1]  # none judged there: no line


def with_heuristics(network: int, top_down: int) -> dict:
    """picks(network, network) with random (2 of 8 views) and top-down (``top_down``) judged on the same views."""
    judged = picks(network, network)
    for name, set_picks in judged.items():
        names = HOUSEHOLD if name == "household" else UNSEEN
        set_picks["others"] = {"random": picks(2, 2)[name], "top_down": picks(top_down, top_down)[name]}
        assert list(set_picks["others"]["top_down"]["per_object"]) == names
    return judged


def test_a_hands_networks_are_judged_against_top_down_over_their_seeds_together_where_none_ships():
    above = [row(s, 0, with_heuristics(7, 5), 0.008) for s in (0, 1)]
    level = [row(s, 0, with_heuristics(5, 5), 0.008, start_from="shipped") for s in (0, 1)]
    alone = [row(0, 0, with_heuristics(7, 5), None)]
    result = {"networks": [*above, *level, *alone], "shipped": None, "command": "cmd", "date": "d", "machine": "m",
              "views": 8}
    pooled = [line for line in own_network_section(result, 0.85) if "against top-down on the same views" in line]
    assert len(pooled) == 2  # one line a group of several networks; the lone network's row says "undecided"
    assert "over the 2 networks (label and fit seeds): +25.0 points" in pooled[0]
    assert pooled[0].endswith("**above top-down**.") and "fit started from" not in pooled[0]
    assert "fit started from" in pooled[1] and pooled[1].endswith("+0.0 points [+0.0, +0.0]: **not shown above "
                                                                   "top-down**.")


def test_a_hand_read_from_its_urdf_is_named_so_and_its_networks_are_judged_beside_top_down():
    read = [row(s, 0, with_heuristics(7, 5), 0.008) for s in (0, 1)]
    read += [row(s, 0, with_heuristics(6, 5), 0.008, start_from="shipped") for s in (0, 1)]  # no 2 mm rows
    for entry in read:
        entry["made"] |= {"gripper": "panda", "urdf": "franka_panda/panda.urdf"}
    result = {"networks": read, "shipped": None, "command": "cmd --gripper panda_urdf", "date": "d", "machine": "m",
              "views": 8}
    lines = own_network_section(result, 0.85)
    assert lines[0] == ("## A network made by the two commands, the Franka Panda read from its URDF: "
                        "`cmd --gripper panda_urdf`")
    assert "read from pybullet_data's `franka_panda/panda.urdf`" in lines[2] and "the `panda` hand" not in lines[2]
    assert any("against top-down on the same views" in line and line.endswith("**above top-down**.") for line in lines)
    started = [line for line in lines if line.startswith("Against the networks fitted from fresh weights")]
    assert len(started) == 1 and "over both sets: -12.5 points" in started[0]  # every object one view lower
