"""Grasps planned on an observed cloud: find the support plane, sample candidates on the object's points (GPD
style, core.cloud.grasps), cut each candidate's crop as the training crops are cut, score them with the network,
rank with pose-distance non-maximum suppression. Typed results, JSON-ready."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from onepiece_dist.core.cloud.denoise import denoised
from onepiece_dist.core.cloud.grasps import (
    CloudCandidates,
    SupportPlane,
    dot3,
    sample_cloud_grasps,
    suppress_near,
    voxel_downsample,
)
from onepiece_dist.core.cloud.objects import grasped_centres, separate_objects
from onepiece_dist.core.cloud.outline import OUTLINE_MODELS, outline
from onepiece_dist.core.cloud.support_check import PLANE_TOLERANCE, support_plane
from onepiece_dist.core.cloud.swept_space import SPACE_MODELS, DepthRays, hand_grid, swept_space
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.core.frames import apply_rotation, compose_poses, quat_from_matrix
from onepiece_dist.core.grasp_context import WORLD_DOWN, grasp_context
from onepiece_dist.core.hand_frames import to_panda
from onepiece_dist.errors import CloudRejected, SpecError
from onepiece_dist.plan.observation import Observation, with_viewpoint
from onepiece_dist.plan.redraw import redrawn_scores
from onepiece_dist.plan.scorer import CropRecord, Crops, GraspScorer, cut_crops
from onepiece_dist.plan.targets import SeenObject, grasped_objects, seen_objects, target_object
from onepiece_dist.specs.job import GripperSpec
from onepiece_dist.specs.plan import PlanSpec

THIN_ABOVE, THIN_CELL = 300_000, 0.0015  # points; m (a 320 px view at 0.65 m: about 1.7 mm a pixel)
PREGRASP = 0.05  # m back along the approach, where the hand opens before it moves in (the pick benchmark's)


@dataclass(frozen=True)
class PlannedGrasp:
    """One ranked grasp: ``pose`` (4, 4) ours (gripper frame to the cloud's frame, docs/gripper_frame.md),
    ``panda_pose`` (4, 4) the same grasp as a Franka Panda hand transform (ACRONYM's and GraspGen's convention),
    ``opening`` the opening to approach with (m), ``observed_width`` the observed points' extent between the
    fingers (m), ``score`` the network's success probability, ``points`` observed points in the closing region;
    ``held``: how many of the check's executions on the shape the view implies held (picks.shape_check)."""

    rank: int
    pose: np.ndarray
    panda_pose: np.ndarray
    opening: float
    observed_width: float
    score: float
    points: int
    object: int = 0  # the object told apart it closes on (GraspPlan.objects; 0: the one with the most points)
    held: tuple[int, int] | None = None  # the check's (draws that held, draws executed); None: not checked

    def pregrasp(self) -> np.ndarray:
        """(4, 4) the Panda hand PREGRASP back along its approach (its z) from ``panda_pose``."""
        out = self.panda_pose.copy()
        out[:3, 3] = out[:3, 3] - PREGRASP * out[:3, 2]
        return out

    def to_json(self) -> dict:
        pregrasp = self.pregrasp()
        return {"rank": self.rank, "object": self.object, "score": round(self.score, 6), "opening": self.opening,
                "observed_width": round(self.observed_width, 6), "points": self.points,
                "check": None if self.held is None else {"held": self.held[0], "draws": self.held[1]},
                "pose": np.round(self.pose, 9).tolist(), "panda_pose": np.round(self.panda_pose, 9).tolist(),
                "position": np.round(self.panda_pose[:3, 3], 9).tolist(),
                "quaternion": np.round(quat_from_matrix(self.panda_pose[:3, :3]), 9).tolist(),
                "pregrasp": {"position": np.round(pregrasp[:3, 3], 9).tolist(),
                             "quaternion": np.round(quat_from_matrix(pregrasp[:3, :3]), 9).tolist()}}


@dataclass(frozen=True)
class PlanCounts:
    """Where the tried candidates of one observation went: placements sampled, those that collided with the
    cloud, those below the support plane, those whose crop held too few points, the candidates left, and (in a
    plan) how many the network scored."""

    sampled: int
    collided: int
    below_plane: int
    too_few_points: int
    candidates: int
    scored: int = 0

    def to_json(self) -> dict[str, int]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Proposals:
    """The candidates of one observation before ranking: poses (n, 4, 4), their crops, the object's points (the
    cloud less the support plane), the plane (or None), where the tried candidates went, the seconds each step
    took and the camera's position (or None)."""

    poses: np.ndarray
    crops: Crops
    object_points: np.ndarray
    plane: SupportPlane | None
    counts: PlanCounts
    seconds: dict[str, float] = field(default_factory=dict)
    viewpoint: np.ndarray | None = None
    top_down: int = 0  # the last this many proposals are top-down grasps (PlanSpec.top_down)
    cloud: np.ndarray | None = None  # the observed cloud the crops were cut from, the table's points too
    apart: tuple[np.ndarray, ...] | None = None  # the objects told apart (core.cloud.objects)


@dataclass(frozen=True)
class GraspPlan:
    """The ranked grasps of one observation, with the counts and timings that produced them."""

    source: str
    grasps: tuple[PlannedGrasp, ...]
    counts: PlanCounts
    plane: SupportPlane | None
    seconds: dict[str, float]
    notes: tuple[str, ...] = ()
    objects: tuple[SeenObject, ...] = ()  # the objects told apart (plan.targets), largest first

    def transformed(self, pose: np.ndarray) -> GraspPlan:
        """The same plan in another frame: ``pose`` (4, 4) maps the planning frame (a camera's) into it (a robot's
        base). Planning in the camera's frame and moving the result keeps the grasps those of the camera's cloud."""
        pose = np.asarray(pose, dtype=np.float64)
        grasps = tuple(dataclasses.replace(g, pose=compose_poses(pose, g.pose),
                                           panda_pose=compose_poses(pose, g.panda_pose)) for g in self.grasps)
        plane = None
        if self.plane is not None:
            normal = apply_rotation(pose[:3, :3], self.plane.normal)
            plane = dataclasses.replace(self.plane, normal=normal,
                                        offset=self.plane.offset - float(dot3(normal, pose[:3, 3])))
        return dataclasses.replace(self, grasps=grasps, plane=plane, objects=tuple(o.moved(pose) for o in self.objects))

    def to_json(self) -> dict:
        plane = None if self.plane is None else {"normal": np.round(self.plane.normal, 9).tolist(),
                                                 "offset": round(self.plane.offset, 9),
                                                 "points": int(self.plane.inliers.sum()),
                                                 "depth_noise": round(self.plane.noise, 6)}
        return {"source": self.source, "frame": "the cloud's frame (the robot's base with a camera pose); pose: "
                "ours (u approach, v closing, origin at the palm centre); panda_pose, and position + quaternion "
                "(x, y, z, w): the Franka Panda hand (z approach, x closing, origin at the hand base); pregrasp: "
                "that hand 5 cm back along z",
                "counts": self.counts.to_json(), "support_plane": plane, "notes": list(self.notes),
                "objects": [o.to_json() for o in self.objects],
                "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
                "grasps": [g.to_json() for g in self.grasps]}


def propose(observation: Observation, record: CropRecord, spec: PlanSpec, rng: np.random.Generator) -> Proposals:
    """Support plane, candidates on the object's points, and their crops (those with fewer than
    ``spec.min_points`` observed points inside dropped)."""
    clock = time.perf_counter()
    points, gripper = observation.points, record.gripper
    if len(points) > THIN_ABOVE:  # millions of points: thinned to about a depth camera's density first
        points = _thin(points, THIN_CELL)
    plane = None
    if spec.support_plane == "auto":
        up = None if observation.viewpoint is None else observation.viewpoint - points.mean(axis=0)
        plane = support_plane(points, rng, towards=up, up=observation.up)
    if plane is not None and spec.denoise == "auto":
        plane, objects = denoised(points, plane, PLANE_TOLERANCE)
    else:
        objects = points[~plane.inliers] if plane is not None else points
    table = points[plane.inliers] if plane is not None else np.zeros((0, 3))
    thin, thin_table = _thin(objects, spec.downsample), _thin(table, spec.downsample)
    found = sample_cloud_grasps(thin, spec.candidates, gripper, rng, observation.viewpoint, thin_table, plane,
                                spec.orientations, spec.table_clearance)
    sampled = time.perf_counter()
    apart = separate_objects(objects) if spec.objects_apart else [objects]
    added = (np.concatenate([top_down_grasps(o, gravity(plane), gripper) for o in apart]) if spec.top_down
             else np.zeros((0, 4, 4)))  # each object's: the top of two objects apart is neither's
    poses = np.concatenate([found.poses, added]) if len(added) else found.poses
    seen = Seen(objects, points, plane, observation.viewpoint, tuple(apart))
    crops, keep = planned_crops(seen, poses, record, rng, spec.min_points)
    counts = _counts(found, int(np.sum(~keep)), len(added))
    return Proposals(poses[keep], crops, objects, plane, counts,
                     {"sample": sampled - clock, "crop": time.perf_counter() - sampled}, observation.viewpoint,
                     int(np.sum(keep[len(found.poses):])), points, seen.apart)


@dataclass(frozen=True)
class Seen:
    """What a crop reads of one observation: the object's ``points`` (the cloud less the support plane), the whole
    ``cloud`` (the table's points too), the support ``plane`` (or None) and the camera's ``viewpoint`` (or None)."""

    objects: np.ndarray
    cloud: np.ndarray
    plane: SupportPlane | None
    viewpoint: np.ndarray | None
    apart: tuple[np.ndarray, ...] | None = None  # the objects told apart (core.cloud.objects), where known

    def separate(self) -> list[np.ndarray]:
        """The objects of ``objects`` told apart (core.cloud.objects.separate_objects): ``[objects]`` for one."""
        return list(self.apart) if self.apart is not None else separate_objects(self.objects)

    @classmethod
    def of(cls, proposals: Proposals) -> Seen:
        cloud = proposals.object_points if proposals.cloud is None else proposals.cloud
        return cls(proposals.object_points, cloud, proposals.plane, proposals.viewpoint, proposals.apart)


def planned_crops(seen: Seen, poses: np.ndarray, record: CropRecord, rng: np.random.Generator,
                  min_points: int = 0) -> tuple[Crops, np.ndarray]:
    """Each of ``poses``' crop as the planner cuts it (cut_crops) with every input ``record``'s network reads (the
    grasp's context; the swept space where the camera's position is known; the outline), those with fewer than
    ``min_points`` observed points inside dropped: (crops, (n,) bool which were kept)."""
    gripper = record.gripper
    crops, keep = cut_crops(seen.objects, poses, record, rng).holding(min_points)
    centres = grasped_centres(seen.separate(), poses[keep], gripper.closing_depth, gripper.closing_width,
                              gripper.closing_height)
    crops = with_context(crops, poses[keep], centres, gravity(seen.plane), gripper.closing_depth)
    if seen.viewpoint is not None and record.model in SPACE_MODELS:  # 10-20 ms a view: only when read
        crops = with_space(crops, poses[keep], seen.cloud, seen.viewpoint, gripper)
    if record.model in OUTLINE_MODELS:
        crops = with_outline(crops, poses[keep], seen.objects, gripper.closing_depth)
    return crops, keep


def gravity(plane: SupportPlane | None) -> np.ndarray:
    """(3,) down: against the support plane's normal where one was found, else the cloud frame's -z."""
    return WORLD_DOWN if plane is None else -plane.normal


def with_context(crops: Crops, poses: np.ndarray, centre: np.ndarray, down: np.ndarray,
                 closing_depth: float, eye: np.ndarray | None = None) -> Crops:
    """``crops`` of ``poses`` with each grasp's context: ``down`` and the object's ``centre`` (3,) (or each grasp's
    object's, (n, 3): core.cloud.objects.grasped_centres), seen from the gripper (core.grasp_context); with
    ``eye``, the direction to the camera too."""
    return dataclasses.replace(crops, context=grasp_context(poses, centre, down, closing_depth, eye))


def with_outline(crops: Crops, poses: np.ndarray, points: np.ndarray, closing_depth: float) -> Crops:
    """``crops`` of ``poses`` with the object's ``points`` seen from each grasp (core.cloud.outline)."""
    return dataclasses.replace(crops, outline=outline(points, poses, closing_depth))


def with_space(crops: Crops, poses: np.ndarray, points: np.ndarray, eye: np.ndarray, gripper: GripperSpec) -> Crops:
    """``crops`` of ``poses`` with the hand's swept space as the camera at ``eye`` saw the cloud ``points`` (every
    observed point, the table's too: core.cloud.swept_space)."""
    grid = hand_grid(gripper.palm_depth, gripper.closing_depth, gripper.max_opening / 2 + gripper.finger_thickness,
                     max(gripper.finger_height, gripper.closing_height) / 2)
    return dataclasses.replace(crops, space=swept_space(DepthRays.of(points, eye), poses, grid))


def _thin(points: np.ndarray, cell: float) -> np.ndarray:
    return points[voxel_downsample(points, cell)] if cell > 0 and len(points) else points


def _counts(found: CloudCandidates, empty: int, added: int = 0) -> PlanCounts:
    return PlanCounts(found.sampled + added, found.collided, found.below_plane, empty,
                      len(found.poses) + added - empty)


def rank(proposals: Proposals, scores: np.ndarray, record: CropRecord, spec: PlanSpec,
         keep: int | None = None) -> tuple[PlannedGrasp, ...]:
    """The best ``keep`` (default ``spec.top_k``) proposals by ``scores`` (n,) after non-maximum suppression."""
    chosen = suppress_near(proposals.poses, scores, record.gripper, spec.nms_distance, spec.nms_angle_deg,
                           keep or spec.top_k)
    return _planned(proposals, scores, record.gripper, chosen)


def _planned(proposals: Proposals, scores: np.ndarray, gripper: GripperSpec, chosen) -> tuple[PlannedGrasp, ...]:
    """The proposals ``chosen`` (indices, best first) as planned grasps ranked 1, 2, ..."""
    panda = to_panda(proposals.poses[chosen], gripper.finger_length) if len(chosen) else np.zeros((0, 4, 4))
    objects = grasped_objects(proposals.apart, proposals.poses[list(chosen)], gripper)
    return tuple(PlannedGrasp(rank + 1, proposals.poses[i], panda[rank], gripper.max_opening,
                              _observed_width(proposals.crops.points[i]), float(scores[i]),
                              int(proposals.crops.counts[i]), int(objects[rank])) for rank, i in enumerate(chosen))


def best_top_down(proposals: Proposals, scores: np.ndarray, record: CropRecord) -> PlannedGrasp | None:
    """The best-scored of the view's top-down grasps (PlanSpec.top_down: the last proposals), None without them."""
    if not proposals.top_down:
        return None
    first = len(proposals.poses) - proposals.top_down
    return _planned(proposals, scores, record.gripper, [first + int(np.argmax(scores[first:]))])[0]


def _observed_width(points: np.ndarray) -> float:
    v = points[:, 1].astype(np.float64)
    return float(v.max() - v.min()) if len(v) else 0.0


MIN_OBJECT_POINTS = 20  # off the support plane: fewer is noise on the table, not an object


def _refuse_plane_alone(observation: Observation, proposals: Proposals) -> None:
    plane = proposals.plane
    if plane is None or len(proposals.object_points) >= MIN_OBJECT_POINTS:
        return
    normal = ", ".join(f"{v:+.2f}" for v in plane.normal)
    raise CloudRejected(f"{observation.source}: no object above the plane: {int(plane.inliers.sum())} of "
                        f"{len(observation.points)} points lie on one plane (normal {normal}) and "
                        f"{len(proposals.object_points)} off it: is the object in view, or already taken?")


# a check of the first ranked grasps (their proposals, the gripper) that returns them reordered: the planner holds
# no simulator, so one is handed in (picks.shape_check.view_check) where the spec asks for it (check_first)
GraspCheck = Callable[[tuple[PlannedGrasp, ...], Proposals, GripperSpec, int], tuple[PlannedGrasp, ...]]


def checked_first(grasps: tuple[PlannedGrasp, ...], proposals: Proposals, gripper: GripperSpec, count: int,
                  check: GraspCheck, extra: PlannedGrasp | None = None, more: int = 0) -> tuple[PlannedGrasp, ...]:
    """``grasps`` (ranked) with their first ``count`` reordered by ``check``, ``extra`` checked beside them (last
    on ties; taken out of the rest where it is there), the next ``more`` checked too where none of those held
    every draw; the rest as they were; ranks numbered again."""
    first, rest = grasps[:count], grasps[count:]
    if extra is not None and not any(np.array_equal(g.pose, extra.pose) for g in first):
        first, rest = (*first, extra), tuple(g for g in rest if not np.array_equal(g.pose, extra.pose))
    later, rest = rest[:more], rest[more:]
    ordered = check((*first, *later), proposals, gripper, len(later)) + rest
    return tuple(dataclasses.replace(g, rank=k + 1) for k, g in enumerate(ordered))


def check_ranked(grasps: tuple[PlannedGrasp, ...], proposals: Proposals, scores: np.ndarray, record: CropRecord,
                 spec: PlanSpec, check: GraspCheck) -> tuple[PlannedGrasp, ...]:
    """``grasps`` (ranked) with the first ``spec.check_first`` reordered by ``check``, the best top-down grasp
    checked beside them where ``spec.check_top_down`` asks, the next ``spec.check_more`` where none of those held
    every draw (checked_first): the planner's and the pick benchmark's one check."""
    extra = best_top_down(proposals, scores, record) if spec.check_top_down else None
    return checked_first(grasps, proposals, record.gripper, spec.check_first, check, extra, spec.check_more)


def checked_count(spec: PlanSpec) -> int:
    """How many ranked grasps the check may execute (check_first, then check_more where none of those held)."""
    return spec.check_first + spec.check_more * bool(spec.check_first)


def plan_grasps(observation: Observation, scorer: GraspScorer, spec: PlanSpec | None = None,
                check: GraspCheck | None = None) -> GraspPlan:
    """The ranked grasps on ``observation`` by ``scorer``'s network (seeded by ``spec.seed``; default PlanSpec),
    the first ``spec.check_first`` reordered by ``check``."""
    spec = spec or PlanSpec()
    if spec.check_first and check is None:
        raise SpecError(f"check_first={spec.check_first} checks grasps in simulation, which this call has none "
                        "of: plan through onepiece_dist.api.plan_grasps (or `onepiece grasp`), or set check_first=0 "
                        "for the network's order alone")
    observation, notes = with_viewpoint(observation, spec)
    rng = np.random.default_rng([spec.seed, 49])
    proposals = propose(observation, scorer.record, spec, rng)
    _refuse_plane_alone(observation, proposals)
    clock = time.perf_counter()
    scores = on_target(proposals, scores_of(proposals, scorer, spec), scorer.gripper, spec, observation.source)
    scored = time.perf_counter()
    grasps = rank(proposals, scores, scorer.record, spec, keep=max(spec.top_k, checked_count(spec)))
    grasps = tuple(g for g in grasps if np.isfinite(g.score))
    ranked = time.perf_counter()
    if spec.check_first:
        grasps = check_ranked(grasps, proposals, scores, scorer.record, spec, check)
    grasps = grasps[: spec.top_k]
    seconds = {**proposals.seconds, "score": scored - clock, "rank": ranked - scored}
    if spec.check_first:
        seconds["check"] = time.perf_counter() - ranked
    seconds["total"] = sum(seconds.values())
    counts = dataclasses.replace(proposals.counts, scored=len(scores))
    return GraspPlan(observation.source, grasps, counts, proposals.plane, seconds, notes + _unchecked(spec, proposals),
                     seen_objects(proposals.apart))


def scores_of(proposals: Proposals, scorer: GraspScorer, spec: PlanSpec) -> np.ndarray:
    """``scorer``'s scores of ``proposals``, over ``spec.score_draws`` draws of the points (plan.redraw)."""
    seen = Seen.of(proposals)
    return redrawn_scores(proposals.crops, proposals.poses, scorer, spec,
                          lambda poses, rng: planned_crops(seen, poses, scorer.record, rng)[0])


def on_target(proposals: Proposals, scores: np.ndarray, gripper: GripperSpec, spec: PlanSpec, source: str
              ) -> np.ndarray:
    """``scores`` with every proposal that does not close on ``spec.target``'s object made -inf (none without a
    target)."""
    if spec.target is None:
        return scores
    wanted = target_object(proposals.apart or (proposals.object_points,), np.asarray(spec.target), source)
    mine = grasped_objects(proposals.apart, proposals.poses, gripper) == wanted
    return np.where(mine, scores, -np.inf)


def _unchecked(spec: PlanSpec, proposals: Proposals) -> tuple[str, ...]:
    """A note where the spec asks for the check and the cloud gives it no support plane to stand its shape on."""
    if not spec.check_first or proposals.plane is not None:
        return ()
    return (f"the first {spec.check_first} grasps are in the network's order, not checked: the check stands the "
            "shape the view implies on a support plane, and this cloud has none (--no-plane, or none found)",)
