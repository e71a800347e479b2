"""What orders the network's best grasps (issue 55): the planner's crops cut again at any pose are its own crops of
that pose, a grasp scored under the pick trials' pose noise, and what one view shows of each grasp."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.mesh import box_mesh
from onepiece_dist.plan import GraspScorer, Observation
from onepiece_dist.plan.planner import Seen, planned_crops, propose
from onepiece_dist.plan.robust import perturbed_scores
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PlanSpec
from tests.test_plan import _floor, seen_cloud

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def box_view():
    """A 3 x 5 x 2 cm box on a floor seen by one camera, its candidates proposed for the shipped network."""
    scorer = GraspScorer(shipped_network(), device="cpu")
    seen = seen_cloud(box_mesh((0.03, 0.05, 0.02)), eye=(0.3, 0.1, 0.4))
    observation = Observation(np.vstack([seen.points, _floor(-0.0101)]), seen.viewpoint, "box on a floor")
    proposals = propose(observation, scorer.record, PlanSpec(), np.random.default_rng(0))
    return scorer, proposals


def test_a_crop_cut_again_at_a_proposals_pose_is_the_proposals_crop(box_view):
    scorer, proposals = box_view
    again, keep = planned_crops(Seen.of(proposals), proposals.poses, scorer.record, np.random.default_rng(3))
    assert keep.all()
    assert np.array_equal(again.codes, proposals.crops.codes)
    assert np.array_equal(again.counts, proposals.crops.counts)
    assert np.array_equal(again.context, proposals.crops.context)  # the inputs the network reads, not the crop alone


def test_a_grasp_scored_under_pose_noise_moves_with_the_noise_and_repeats_with_the_seed(box_view):
    scorer, proposals = box_view
    indices = np.arange(min(6, len(proposals.poses)))
    nominal = scorer.score(proposals.crops.subset(indices))

    def scores(translation, rotation, seed=1):
        return perturbed_scores(proposals, indices, scorer, scorer.record, 8, translation, rotation,
                                np.random.default_rng(seed))

    still, moved = scores(0.0, 0.0), scores(0.02, 0.5)
    assert still.shape == moved.shape == (len(indices), 8)
    assert np.abs(still.mean(axis=1) - nominal).max() < 0.05  # no noise: the grasp itself, points resampled
    assert np.abs(moved - nominal[:, None]).mean() > 2 * np.abs(still - nominal[:, None]).mean()
    assert np.array_equal(scores(0.003, 0.05), scores(0.003, 0.05))
    assert not np.array_equal(scores(0.003, 0.05), scores(0.003, 0.05, seed=2))


def test_what_a_view_shows_of_its_top_down_grasps(box_view):
    from onepiece_dist.picks.rank_features import FEATURES, rank_features

    scorer, proposals = box_view
    n = len(proposals.poses)
    indices = np.array([0, n - 3, n - 2, n - 1])  # a sampled grasp, then the three top-down ones
    scores = np.linspace(0, 1, n)
    features = dict(zip(FEATURES, rank_features(proposals, indices, scores, scorer.gripper).T, strict=True))
    assert np.array_equal(features["score"], scores[indices])
    assert np.array_equal(features["top_down"], [0, 1, 1, 1])
    assert np.allclose(features["from_above"][1:], 1) and np.allclose(features["closing_tilt"][1:], 0, atol=1e-6)
    assert np.array_equal(features["filled"], proposals.crops.counts[indices])
    assert np.allclose(features["object_height"], np.ptp(proposals.object_points[:, 2]), atol=1e-6)
    assert (features["observed_width"] <= scorer.gripper.max_opening + 1e-3).all()
    assert (features["object_span"] >= features["observed_width"] - 1e-3).all()
    assert ((features["antipodal"] >= 0) & (features["antipodal"] <= 1)).all()  # a cosine: one view's contacts
