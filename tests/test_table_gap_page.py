"""The picks page's section on how low the open gripper may go over the table (issue 55): a height is kept by the
trials' rule on the household objects, and another hand is told what the kept height does on it."""

from __future__ import annotations

import copy
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _result(gripper: str = "") -> dict:
    result = json.loads((ROOT / "benchmarks" / "results" / "pick_table_gap.json").read_text())
    return {**result, "command": result["command"] + (f" --gripper {gripper}" if gripper else "")}


def test_a_height_is_kept_by_the_household_interval_and_another_hand_hears_what_it_does():
    from benchmarks.pages.pick_table_gap_section import table_gap_section

    result = _result()
    kept = "\n".join(table_gap_section(result))
    assert "8 mm: kept" in kept and "The planner keeps 8 mm" in kept
    lowered = copy.deepcopy(result)
    lowered["runs"]["0.008"]["versus"]["household"]["interval"] = [-0.01, 0.05]
    assert "8 mm: not kept" in "\n".join(table_gap_section(lowered))  # the rule reads the interval, not the mean
    assert "views 24 to 39 alone" in kept  # the views no choice saw, on the box gripper's page only
    panda = _result("panda")
    panda["runs"]["0.008"]["versus"]["all objects"]["interval"] = [-0.08, -0.01]
    other = "\n".join(table_gap_section(panda))
    assert "the Franka hand" in other and "shows a loss" in other and "views 24 to 39" not in other
    panda["runs"]["0.008"]["versus"]["all objects"]["interval"] = [-0.01, 0.04]
    assert "neither a gain nor a loss" in "\n".join(table_gap_section(panda))
