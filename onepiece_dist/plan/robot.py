"""From a camera's files to grasps in the robot's frame, in one call (issue 56): what `onepiece grasp` does, through
``onepiece_dist.api.plan_grasps``. The cloud file or depth image is read, in the camera's frame when a camera pose
is given (then planned there and moved to the base frame: the grasps are those of the camera's cloud), cropped to
the workspace, and planned by the checkpoint's network, or the shipped one."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.frames import invert_poses, transform_points
from onepiece_dist.errors import CloudRejected
from onepiece_dist.plan.camera_files import (
    check_looks_down,
    crop_to_workspace,
    depth_observation,
    in_frame,
    read_camera_pose,
    read_intrinsics,
    read_workspace,
    with_known_up,
)
from onepiece_dist.plan.observation import Observation, read_cloud
from onepiece_dist.plan.planner import GraspCheck, GraspPlan, plan_grasps
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.plan.shipped import PlanningNetwork, planning_network
from onepiece_dist.specs.job import GripperSpec
from onepiece_dist.specs.plan import PlanSpec


@dataclass(frozen=True)
class RobotPlan:
    """The plan (in the base frame with a camera pose, else the cloud's), the observation in that frame, the
    gripper it was planned for, the checkpoint that scored it (None: the shipped network), the frame's name, and
    the gripper the shipped network was trained for where it was carried to this one (plan.shipped)."""

    plan: GraspPlan
    observation: Observation
    gripper: GripperSpec
    checkpoint: str | None
    frame: str
    carried_from: str | None = None


def read_observation(cloud: str | Path, intrinsics: str | None = None, depth_scale: float | None = None,
                     viewpoint: tuple[float, float, float] | None = None, camera_pose: str | Path | None = None,
                     workspace: str | None = None, drop_flying: float = 0.0) -> tuple[Observation, np.ndarray | None]:
    """The observation to plan on (in the camera's frame when ``camera_pose`` is given, with that pose), else in
    the cloud's own frame (and None); a depth image's flying pixels dropped at ``drop_flying`` (m; PlanSpec)."""
    pose = None if camera_pose is None else read_camera_pose(camera_pose)
    view = None if viewpoint is None else np.asarray(viewpoint, dtype=np.float64)
    if intrinsics is not None:
        observation = depth_observation(cloud, read_intrinsics(intrinsics), depth_scale, drop_flying)
    elif drop_flying > 0:
        raise CloudRejected(f"{cloud}: drop_flying (--drop-flying) finds flying pixels on a depth image, and a "
                            "point cloud has no pixel neighbours: give the depth image with --intrinsics, or "
                            "leave drop_flying at 0")
    else:
        observation = read_cloud(cloud, view if view is not None else (np.zeros(3) if pose is not None else None))
    if pose is not None:
        check_looks_down(observation, pose, camera_pose)
        observation = with_known_up(observation, pose)
    if workspace is not None:
        observation = crop_to_workspace(observation, *read_workspace(workspace), pose)
    return observation, pose


def plan_from_files(cloud: str | Path, checkpoint: str | Path | None = None, spec: PlanSpec | None = None,
                    intrinsics: str | None = None, depth_scale: float | None = None,
                    viewpoint: tuple[float, float, float] | None = None, camera_pose: str | Path | None = None,
                    workspace: str | None = None, gripper: GripperSpec | None = None,
                    check: GraspCheck | None = None) -> RobotPlan:
    """Grasps on a cloud file or depth image (``intrinsics``: fx,fy,cx,cy or a JSON file), by ``checkpoint``'s
    network (None: the shipped one), in the robot's base frame when ``camera_pose`` (a JSON file) is given; the
    first ``spec.check_first`` reordered by ``check`` (planner.plan_grasps)."""
    spec = spec or PlanSpec()
    observation, pose = read_observation(cloud, intrinsics, depth_scale, viewpoint, camera_pose, workspace,
                                         spec.drop_flying)
    if pose is not None and spec.target is not None:  # the target is given in the base frame; planning is not
        target = transform_points(np.array([spec.target]), invert_poses(pose[None])[0])[0]
        spec = spec.model_copy(update={"target": tuple(float(v) for v in target)})
    network = PlanningNetwork(Path(checkpoint)) if checkpoint is not None else planning_network(gripper, spec.carry)
    scorer = GraspScorer(network.path, gripper, spec.device, carried=network.carried)
    plan = plan_grasps(observation, scorer, spec, check)
    if pose is not None:
        plan, observation = plan.transformed(pose), in_frame(observation, pose)
    frame = "the robot's base frame" if pose is not None else "the cloud's frame"
    return RobotPlan(plan, observation, scorer.gripper, None if checkpoint is None else str(checkpoint), frame,
                     network.carried_from)
