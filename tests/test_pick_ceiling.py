"""The pool's ceiling without the draw (issue 55, picks.draws.view_ceilings): each view's candidates executed at
the draw every chooser meets, those that picked drawn again, the chosen one judged at a draw no selection saw."""

from __future__ import annotations

import pytest

from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.draws import view_ceilings
from onepiece_dist.picks.object_picks import pick_object
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PickSpec

pytestmark = pytest.mark.sim


@pytest.mark.slow
def test_the_one_draw_share_is_the_oracles_and_a_view_is_judged_at_a_draw_no_selection_saw(tmp_path):
    spec = PickSpec(objects="primitives[0:1]", checkpoint=str(shipped_network()), output=str(tmp_path), views=1,
                    attempts=1, pictures=0, methods=("oracle",), plan={"candidates": 48, "top_down": True},
                    sim={"label_trials": 2, "success": "every_trial"})
    ref = resolve_source(spec.objects)[0]
    _, name, views, reason = view_ceilings(spec, ref, 0, 2, 4)
    assert reason == "" and len(views) == 1
    oracle = pick_object(spec, ref, 0)
    for view, seen in zip(views, oracle.views, strict=True):
        assert view.candidates == seen.candidates > 0
        assert view.one_draw == (seen.pool_picked > 0)  # draw 0 is the oracle's own
        assert view.repeated <= seen.pool_picked  # a candidate kept picked at draw 0 and at draw 1
        assert (view.first_held_out is None) == (view.best_held_out is None) == (view.repeated == 0)
    assert any(view.best_held_out for view in views)  # a primitive on the table has grasps that pick again
    _, _, again, _ = view_ceilings(spec, ref, 0, 2, 4)
    assert again == views  # every draw has its own generator: the same spec gives the same ceiling
