"""Clearing the table (picks.clearance, VGN's declutter protocol): objects leave as they are picked, two failed
rounds in a row end it, the same seed clears the same way, and the page says the rates with their intervals."""

from __future__ import annotations

import pytest


@pytest.mark.sim
def test_three_boxes_are_cleared_round_by_round_the_same_way_twice(tmp_path):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clearance import MAX_FAILURES, MAX_ROUNDS, clear_scenes
    from onepiece_dist.picks.clutter import groups_of
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    spec = PickSpec(objects="primitives[0:3]", checkpoint=str(shipped_network()), clutter=3, views=1,
                    output=str(tmp_path), methods=("network", "top_down"), plan=PlanSpec(check_draws=1))
    group = groups_of(resolve_source(spec.objects), 3)[0]
    runs = [clear_scenes(spec, group, 0) for _ in range(2)]
    assert runs[0].views == runs[1].views and runs[0].status == "ok"
    cleared = runs[0].views[0]
    assert cleared.objects == 3 and set(cleared.rounds) == {"network", "top_down"}
    for rounds in cleared.rounds.values():
        assert sum(rounds) <= 3 and len(rounds) <= MAX_ROUNDS * 3
        ended_clear, ended_failing = sum(rounds) == 3, rounds[-MAX_FAILURES:] == (False,) * MAX_FAILURES
        assert ended_clear or ended_failing or len(rounds) == MAX_ROUNDS * 3
        assert not any(rounds[k] is False and rounds[k + 1] is False for k in range(len(rounds) - 2))
    assert cleared.rounds["top_down"] == (True, True, True)  # boxes standing apart, picked from above one by one


def test_the_clearance_page_names_the_best_heuristic_and_every_rate_with_its_interval():
    from benchmarks.experiments.pick_clearance import rates
    from benchmarks.pages.pick_clearance_section import clearance_section

    scenes = {"a+b+c+d": {"network": {"cleared": 7, "objects": 8, "rounds": 9},
                          "top_down": {"cleared": 4, "objects": 8, "rounds": 8}},
              "b+c+d+a": {"network": {"cleared": 8, "objects": 8, "rounds": 8},
                          "top_down": {"cleared": 2, "objects": 8, "rounds": 6}}}
    measured = {m: rates(scenes, m) for m in ("network", "top_down")}
    assert measured["network"]["declutter"]["rate"] == pytest.approx((7 / 8 + 1) / 2)
    assert measured["top_down"]["success"]["rate"] == pytest.approx((4 / 8 + 2 / 6) / 2)
    result = {"command": "c", "date": "d", "machine": "m", "objects": 4, "views": 2, "methods": ["network", "top_down"],
              "sets": {"household": {"scenes": scenes}}, "rates": {"household": measured, "all scenes": measured}}
    lines = clearance_section(result)
    assert any(line.startswith("Over all 2 scenes the shipped planner clears **94%** [88%, 100%] of the objects") and
               "+56 points over the best heuristic (top-down across the narrow axis of the largest object, 38%)"
               in line for line in lines)
    assert "| household | network on the view (as shipped) | 94% [88%, 100%] | 89% [78%, 100%] |" in lines
    assert lines[0].startswith("## Clearing the table: ") and "does not push its neighbours" in lines[2]
    piled = clearance_section({**result, "pile": True})
    assert piled[0].startswith("## Clearing a pile: ") and "`--clutter 4 --pile`" in piled[2]
    assert "so what leaned on it falls" in piled[2] and "does not push" not in piled[2]
