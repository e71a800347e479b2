"""The pool's ceiling without the draw (issue 55, picks.draws.view_ceilings): each view's candidates executed at
the draw every chooser meets, those that picked drawn again, the chosen one judged at a draw no selection saw."""

from __future__ import annotations

import pytest

from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.draws import CeilingDraws, view_ceilings
from onepiece_dist.picks.object_picks import pick_object
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PickSpec

pytestmark = pytest.mark.sim


def _one_view(folder, method: str) -> PickSpec:
    """One view of a primitive on the table, a small pool with the top-down grasps, two trials a pick."""
    return PickSpec(objects="primitives[0:1]", checkpoint=str(shipped_network()), output=str(folder), views=1,
                    attempts=1, pictures=0, methods=(method,), plan={"candidates": 48, "top_down": True},
                    sim={"label_trials": 2, "success": "every_trial"})


@pytest.mark.slow
def test_the_one_draw_share_is_the_oracles_and_a_view_is_judged_at_a_draw_no_selection_saw(tmp_path):
    spec = _one_view(tmp_path, "oracle")
    ref = resolve_source(spec.objects)[0]
    draws = CeilingDraws(screen=2, selection=4, shortlist=2, judge=2)
    _, name, views, reason = view_ceilings(spec, ref, 0, draws)
    assert reason == "" and len(views) == 1
    oracle = pick_object(spec, ref, 0)
    for view, seen in zip(views, oracle.views, strict=True):
        assert view.candidates == seen.candidates > 0
        assert view.one_draw == (seen.pool_picked > 0)  # draw 0 is the oracle's own
        assert view.repeated <= seen.pool_picked  # a candidate kept picked at draw 0 and at draw 1
        assert (view.first_held_out is None) == (view.best_held_out is None) == (view.repeated == 0)
        assert view.best_held_out is None or view.best_held_out in (0.0, 0.5, 1.0)  # a share of 2 judging draws
    assert any(view.best_held_out for view in views)  # a primitive on the table has grasps that pick again
    _, _, again, _ = view_ceilings(spec, ref, 0, draws)
    assert again == views  # every draw has its own generator: the same spec gives the same ceiling


@pytest.mark.slow
def test_the_networks_first_ranked_grasp_at_draw_0_is_its_first_attempt_and_is_drawn_again(tmp_path):
    from onepiece_dist.picks.draws import ranked_draws

    spec = _one_view(tmp_path, "network")
    ref = resolve_source(spec.objects)[0]
    _, _, views, reason = ranked_draws(spec, ref, 0, 4, 3)
    picked = pick_object(spec, ref, 0)
    assert reason == "" and len(views) == 1
    view = views[0]
    assert 0 < len(view.scores) <= 4 and list(view.scores) == sorted(view.scores, reverse=True)
    assert all(len(d) == 3 for d in view.draws) and len(view.top_down) == len(view.scores)
    assert view.draws[0][0] == picked.views[0].attempts["network"][0]  # draw 0: the chooser's own execution
    assert any(any(d) for d in view.draws)
