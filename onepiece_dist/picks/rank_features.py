"""What one view shows of a planned grasp, in numbers a prior can weigh beside the network's score (issue 55: do
they tell the surer of the network's best grasps apart?). Gravity is the support plane's normal turned over (the
planner's down); heights are along it from the object's lowest observed point."""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.cloud.grasps import antipodal_scores, cloud_normals
from onepiece_dist.core.grasp_context import closing_centres, object_centre
from onepiece_dist.plan.planner import Proposals, gravity
from onepiece_dist.specs.job import GripperSpec

FEATURES = (
    "score",  # the network's success probability
    "top_down",  # 1 for one of the view's top-down grasps
    "from_above",  # the approach's cosine with down: 1 straight down, 0 from the side
    "closing_tilt",  # |cosine| of the closing axis with down: 0 closes level
    "height_fraction",  # where the closing region's centre lies on the object's observed height (0 bottom, 1 top)
    "off_axis",  # m: the closing region's centre from the object's vertical axis through its centre
    "filled",  # observed points inside the closing region
    "observed_width",  # m: the observed points' extent between the fingers
    "object_height",  # m: the observed object's height
    "object_span",  # m: the observed object's extent along the closing axis
    "antipodal",  # the analytic antipodal score on the view's cloud (core.cloud.grasps.antipodal_scores)
)


def rank_features(proposals: Proposals, indices: np.ndarray, scores: np.ndarray, gripper: GripperSpec
                  ) -> np.ndarray:
    """(len(indices), len(FEATURES)) float64: FEATURES of the proposals ``indices`` scored ``scores`` (all)."""
    poses = proposals.poses[indices]
    points = np.asarray(proposals.object_points, dtype=np.float64)
    down = gravity(proposals.plane)
    approach, closing = poses[:, :3, 0], poses[:, :3, 1]
    centres = closing_centres(poses, gripper.closing_depth)
    heights = points @ -down
    base, height = heights.min(), np.ptp(heights)
    offset = centres - object_centre(points)
    level = offset - np.outer(offset @ down, down)
    spans = np.ptp(points @ closing.T, axis=0)
    inside = proposals.crops.points[indices].astype(np.float64)
    normals = cloud_normals(points, points, proposals.viewpoint)
    return np.column_stack([
        scores[indices],
        indices >= len(proposals.poses) - proposals.top_down,
        approach @ down,
        np.abs(closing @ down),
        (centres @ -down - base) / max(height, 1e-9),
        np.linalg.norm(level, axis=1),
        proposals.crops.counts[indices],
        np.ptp(inside[:, :, 1], axis=1),
        np.full(len(indices), height),
        spans,
        antipodal_scores(points, normals, poses, gripper),
    ]).astype(np.float64)
