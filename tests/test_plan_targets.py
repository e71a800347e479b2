"""A plan says which object each grasp closes on, and a target point keeps only the grasps on one object
(plan.targets; `onepiece grasp --target`): in the cloud's frame and, with a camera pose, in the robot's."""

from __future__ import annotations

import json

import numpy as np
import pytest

from onepiece_dist.core.frames import invert_poses, matrix_from_quat, quat_from_matrix, transform_points
from tests.test_objects_apart import APART
from tests.test_plan import _floor
from tests.test_shape_check import seen_box

EYE = (0.3, -0.3, 0.4)
SECOND_TOP = APART + [0.0, 0.0, 0.08]  # a point on the second box's top face


def _two_boxes(path):
    np.save(path, np.vstack([seen_box(), seen_box() + APART, _floor(0.0)]))
    return path


def _near(grasps, centre) -> bool:
    """Every grasp's closing centre lies within a box's reach of ``centre`` (x, y)."""
    return all(np.linalg.norm((g.pose[:3, 3] + 0.04 * g.pose[:3, 0])[:2] - centre[:2]) < 0.06 for g in grasps)


def test_a_plan_lists_the_objects_and_each_grasp_says_which_it_closes_on(tmp_path):
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.specs.plan import PlanSpec

    plan = plan_grasps(_two_boxes(tmp_path / "two.npy"), spec=PlanSpec(check_first=0, top_k=12), viewpoint=EYE).plan
    assert [o.index for o in plan.objects] == [0, 1] and all(o.points > 100 for o in plan.objects)
    centres = sorted(o.centre[0] for o in plan.objects)
    assert centres[0] == pytest.approx(0.0, abs=0.01) and centres[1] == pytest.approx(APART[0], abs=0.01)
    assert {g.object for g in plan.grasps} == {0, 1}  # grasps on both boxes, each knowing its own
    for g in plan.grasps:
        assert _near([g], plan.objects[g.object].centre)
    written = plan.to_json()
    assert [o["index"] for o in written["objects"]] == [0, 1] and "object" in written["grasps"][0]


@pytest.mark.sim
def test_a_target_keeps_the_grasps_on_its_object_checked_and_refuses_a_point_on_none(tmp_path):
    from typer.testing import CliRunner

    from onepiece_dist.api import plan_grasps
    from onepiece_dist.cli.main import app
    from onepiece_dist.errors import CloudRejected
    from onepiece_dist.specs.plan import PlanSpec

    cloud = _two_boxes(tmp_path / "two.npy")
    plan = plan_grasps(cloud, spec=PlanSpec(target=tuple(SECOND_TOP), check_draws=1), viewpoint=EYE).plan
    second = next(o.index for o in plan.objects if o.centre[0] > APART[0] / 2)
    assert len(plan.grasps) > 3 and {g.object for g in plan.grasps} == {second} and "check" in plan.seconds
    assert _near(plan.grasps, APART) and [g.rank for g in plan.grasps] == list(range(1, len(plan.grasps) + 1))
    with pytest.raises(CloudRejected, match=r"no object within 0.05 m of the target \(\+0.300, \+0.000, \+0.050\)"):
        plan_grasps(cloud, spec=PlanSpec(target=(0.3, 0.0, 0.05), check_first=0), viewpoint=EYE)
    ran = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", ",".join(map(str, EYE)), "--target",
                                   "0.3,0,0.05", "--check", "0", "--out", str(tmp_path / "none")])
    assert ran.exit_code == 2 and "Objects seen: object 0 at" in ran.output
    ran = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", ",".join(map(str, EYE)), "--target",
                                   ",".join(map(str, SECOND_TOP)), "--check", "0", "--out", str(tmp_path / "cli")])
    assert ran.exit_code == 0, ran.output
    written = json.loads((tmp_path / "cli" / "grasps.json").read_text())
    assert {g["object"] for g in written["grasps"]} == {second}


def test_a_target_in_the_robots_frame_picks_the_same_object_seen_from_a_turned_camera(tmp_path):
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.specs.plan import PlanSpec

    camera = np.eye(4)  # camera to base: turned 40 degrees about the vertical, where EYE is
    camera[:3, :3] = matrix_from_quat([0.0, 0.0, np.sin(0.35), np.cos(0.35)])
    camera[:3, 3] = EYE
    in_base = np.vstack([seen_box(), seen_box() + APART, _floor(0.0)])
    np.save(tmp_path / "seen.npy", transform_points(in_base, invert_poses(camera[None])[0]))
    (tmp_path / "pose.json").write_text(json.dumps({"position": camera[:3, 3].tolist(),
                                                    "quaternion": quat_from_matrix(camera[:3, :3])}))
    plan = plan_grasps(tmp_path / "seen.npy", spec=PlanSpec(target=tuple(SECOND_TOP), check_first=0),
                       camera_pose=tmp_path / "pose.json").plan
    assert plan.grasps and _near(plan.grasps, APART)  # the base frame's second box
    assert any(o.centre[0] == pytest.approx(APART[0], abs=0.01) for o in plan.objects)  # objects in the base frame
