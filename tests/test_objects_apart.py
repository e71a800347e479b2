"""Objects standing apart in one view are told apart (core.cloud.objects), and the planner's check completes the
shape of the object a grasp closes on, not one hull over both (picks.shape_check)."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.cloud.completion import completed_shape
from onepiece_dist.core.cloud.grasps import SupportPlane
from onepiece_dist.core.cloud.objects import BLOCK, GAP, closed_on, closed_on_each, point_groups, separate_objects
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.specs.plan import PICK_SIM
from tests.test_shape_check import seen_box

FLOOR = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, bool))
APART = np.array([0.09, 0.0, 0.0])  # a second box 5 cm beyond the first's +x face


def test_points_further_apart_than_the_gap_are_separate_objects_and_stray_points_are_none():
    box = seen_box()
    groups = point_groups(np.vstack([box, box + APART]))
    assert len(np.unique(groups)) == 2 and len(np.unique(groups[: len(box)])) == 1
    assert point_groups(np.vstack([box, box + [0.04 + GAP / 2, 0.0, 0.0]])).max() == 0  # touching: one object
    small = seen_box((0.03, 0.03, 0.04))
    apart = separate_objects(np.vstack([box, small + APART]))
    assert [len(p) for p in apart] == [len(box), len(small)]  # largest first
    stray = np.vstack([box, [[0.3, 0.3, 0.05]]])
    whole = separate_objects(stray)
    assert len(whole) == 1 and whole[0] is stray  # one object: every point kept, the stray one too
    assert point_groups(np.zeros((0, 3))).shape == (0,)


def _closed_on_one_by_one(objects, pose, depth, width, height) -> int:
    """The rule as closed_on states it, pose by pose: the most points in the closing region, else the nearest."""
    inside = [np.sum((lambda u: (u[:, 0] >= 0) & (u[:, 0] < depth) & (np.abs(u[:, 1]) < width / 2)
                      & (np.abs(u[:, 2]) < height / 2))((o - pose[:3, 3]) @ pose[:3, :3])) for o in objects]
    centre = pose[:3, 3] + pose[:3, 0] * depth / 2
    return int(np.argmax(inside)) if max(inside) > 0 else int(np.argmin([np.min(np.sum((o - centre) ** 2, 1))
                                                                          for o in objects]))


def test_each_grasp_closes_on_the_object_with_most_points_in_its_region_else_the_nearest():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    box = seen_box()
    objects = [box, seen_box((0.03, 0.03, 0.04)) + APART, box[::3] + [0.0, 0.08, 0.0]]
    poses = np.tile(np.eye(4), (BLOCK // len(box) + 300, 1, 1))  # more than one block of poses an object
    poses[:, :3, :3] = Rotation.random(len(poses), random_state=1).as_matrix()
    poses[:, :3, 3] = rng.uniform([-0.05, -0.05, 0.0], [0.15, 0.13, 0.12], (len(poses), 3))
    depth, width, height = 0.04, 0.08, 0.02
    chosen = closed_on_each(objects, poses, depth, width, height)
    expected = [_closed_on_one_by_one(objects, pose, depth, width, height) for pose in poses]
    assert chosen.tolist() == expected and len(set(expected)) == 3
    assert closed_on(objects, poses[0], depth, width, height) == expected[0]
    assert closed_on_each(objects[:1], poses, depth, width, height).tolist() == [0] * len(poses)


@pytest.mark.sim
def test_a_grasp_beside_a_second_object_is_checked_on_its_own_object_not_on_one_hull_over_both():
    from onepiece_dist.picks.shape_check import held_shares
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network

    gripper = GraspScorer(shipped_network(), device="cpu").gripper
    box = seen_box()
    both = np.vstack([box, box + APART])
    grasp = top_down_grasps(box, np.array([0.0, 0.0, -1.0]), gripper)[0]  # a finger in the space between them
    objects = separate_objects(both)
    mine = closed_on(objects, grasp, gripper.closing_depth, gripper.closing_width, gripper.closing_height)
    assert np.array_equal(objects[mine], box)
    far = grasp.copy()
    far[:3, 3] += [0.0, 0.3, 0.0]  # closes on nothing: the nearest object's
    assert closed_on(objects, far, gripper.closing_depth, gripper.closing_width, gripper.closing_height) == mine
    own = held_shares(completed_shape(box, FLOOR), grasp[None], gripper, PICK_SIM, 4, np.random.default_rng(0))
    joined = held_shares(completed_shape(both, FLOOR), grasp[None], gripper, PICK_SIM, 4, np.random.default_rng(0))
    assert own[0] >= 0.5 and joined[0] == 0.0  # one hull over both fills the space the finger goes into


@pytest.mark.sim
def test_the_planner_checks_each_grasp_on_its_own_object_where_the_view_holds_two(tmp_path):
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_plan import _floor

    cloud = tmp_path / "two.npy"
    np.save(cloud, np.vstack([seen_box(), seen_box() + APART, _floor(0.0)]))
    eye = (0.3, -0.3, 0.4)
    plain = plan_grasps(cloud, spec=PlanSpec(top_k=6, check_first=0), viewpoint=eye).plan
    checked = plan_grasps(cloud, spec=PlanSpec(top_k=6, check_draws=2), viewpoint=eye).plan  # the default: 3
    key = [g.pose.tobytes() for g in plain.grasps]
    assert sorted(g.pose.tobytes() for g in checked.grasps[:3]) == sorted(key[:3])
    assert [g.pose.tobytes() for g in checked.grasps[3:]] == key[3:] and "check" in checked.seconds
    assert all(g.held is None for g in plain.grasps + checked.grasps[3:])  # only what was executed says so
    held = {g.pose.tobytes(): g.held for g in checked.grasps[:3]}
    first = held.pop(key[0])  # the network's first is executed first; the other two unless it held every draw
    assert first is not None and 0 <= first[0] <= first[1] <= 2
    assert all((h is None) == (first == (2, 2)) for h in held.values()), (first, held)
    assert all(h is None or 0 <= h[0] <= h[1] <= 2 for h in held.values())
    assert checked.grasps[0].to_json()["check"] == {"held": checked.grasps[0].held[0],
                                                    "draws": checked.grasps[0].held[1]}
    assert plain.grasps[0].to_json()["check"] is None


def test_a_grasps_context_reads_the_centre_of_the_object_it_closes_on():
    from onepiece_dist.core.grasp_context import grasp_context, object_centre
    from onepiece_dist.plan.planner import Seen, planned_crops
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network

    record = GraspScorer(shipped_network(), device="cpu").record
    gripper, box = record.gripper, seen_box()
    grasps = np.stack([top_down_grasps(box, np.array([0.0, 0.0, -1.0]), gripper)[0],
                       top_down_grasps(box + APART, np.array([0.0, 0.0, -1.0]), gripper)[0]])
    both = np.vstack([box, box + APART])
    crops, keep = planned_crops(Seen(both, both, FLOOR, None), grasps, record, np.random.default_rng(0))
    assert keep.all()
    own = np.stack([grasp_context(grasps[k:k + 1], object_centre(points), np.array([0.0, 0.0, -1.0]),
                                  gripper.closing_depth)[0] for k, points in enumerate((box, box + APART))])
    np.testing.assert_array_equal(crops.context, own)
    alone, _ = planned_crops(Seen(box, box, FLOOR, None), grasps[:1], record, np.random.default_rng(0))
    np.testing.assert_array_equal(alone.context, own[:1])  # one object: its own centre, as before


def test_the_planner_proposes_the_top_down_grasps_of_each_object_apart():
    from onepiece_dist.plan import GraspScorer, Observation
    from onepiece_dist.plan.planner import propose
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_plan import _floor

    record, eye = GraspScorer(shipped_network(), device="cpu").record, np.array([0.3, -0.3, 0.4])
    one = propose(Observation(np.vstack([seen_box(), _floor(0.0)]), eye, "one"), record, PlanSpec(),
                  np.random.default_rng(0))
    two = propose(Observation(np.vstack([seen_box(), seen_box() + APART, _floor(0.0)]), eye, "two"), record,
                  PlanSpec(), np.random.default_rng(0))
    assert one.top_down == 3 and two.top_down == 6
    tops = two.poses[-6:, :3, 3]  # above each box's top, none between them
    assert np.sum(np.abs(tops[:, 0]) <= 0.025) == 3 and np.sum(np.abs(tops[:, 0] - APART[0]) <= 0.025) == 3
