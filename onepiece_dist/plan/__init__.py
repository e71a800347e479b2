"""Grasps planned on what a depth camera sees (docs/planning.md): an observed cloud in, ranked grasps out.

``read_cloud`` / ``depth_to_cloud`` make an :class:`Observation`; :class:`GraspScorer` loads a checkpoint with the
crop it was trained on; :func:`plan_grasps` samples, crops, scores and ranks; :func:`write_plan` writes the JSON and
the picture.
"""

from onepiece_dist.plan.drawing import draw_plan, write_plan
from onepiece_dist.plan.observation import Observation, depth_to_cloud, read_cloud
from onepiece_dist.plan.planner import GraspPlan, PlannedGrasp, plan_grasps
from onepiece_dist.plan.scorer import CropRecord, GraspScorer

__all__ = ["CropRecord", "GraspPlan", "GraspScorer", "Observation", "PlannedGrasp", "depth_to_cloud", "plan_grasps",
           "read_cloud", "draw_plan", "write_plan"]
