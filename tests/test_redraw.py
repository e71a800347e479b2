"""Scores steadied over fresh draws of each crop's points (issue 55, plan.redraw): one draw is the plain score;
more draws average the best candidates' scores over crops cut again from fresh seeded draws, the rest unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.mesh import box_mesh
from onepiece_dist.plan import GraspScorer, Observation, plan_grasps
from onepiece_dist.plan.planner import Seen, planned_crops, propose, scores_of
from onepiece_dist.plan.redraw import REDRAW_STREAM, REDRAWN
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PlanSpec
from tests.test_plan import _floor, seen_cloud

pytestmark = pytest.mark.sim


def test_more_score_draws_average_the_best_candidates_over_fresh_draws_and_leave_the_rest():
    seen = seen_cloud(box_mesh((0.03, 0.05, 0.02)), eye=(0.3, 0.1, 0.4))
    observation = Observation(np.vstack([seen.points, _floor(-0.0101)]), seen.viewpoint, "box on a floor")
    scorer = GraspScorer(shipped_network(), device="cpu")
    low = PlanSpec(table_clearance=0.002)  # the hands may go low over the table: this 2 cm box keeps more than 32
    proposals = propose(observation, scorer.record, low, np.random.default_rng(0))
    one = scores_of(proposals, scorer, low)
    assert np.array_equal(one, scorer.score(proposals.crops))  # one draw: the plain score, every byte
    four = scores_of(proposals, scorer, low.model_copy(update={"score_draws": 4}))
    assert np.array_equal(four, scores_of(proposals, scorer, low.model_copy(update={"score_draws": 4})))  # seeded
    best = np.argsort(-one, kind="stable")[:REDRAWN]
    assert len(one) > REDRAWN and np.array_equal(np.delete(four, best), np.delete(one, best))
    fresh = [scorer.score(planned_crops(Seen.of(proposals), proposals.poses[best], scorer.record,
                                        np.random.default_rng([0, REDRAW_STREAM, draw]))[0]) for draw in (1, 2, 3)]
    assert np.allclose(four[best], np.mean([one[best], *fresh], axis=0))
    assert not np.allclose(four[best], one[best])  # a fresh draw of the points moves a crop's score
    plans = [plan_grasps(observation, scorer, PlanSpec(score_draws=4, check_first=0)) for _ in range(2)]
    assert [g.pose.tolist() for g in plans[0].grasps] == [g.pose.tolist() for g in plans[1].grasps]
