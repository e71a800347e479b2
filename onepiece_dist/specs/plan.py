"""Frozen specs of planning grasps on a camera's cloud (PlanSpec) and of the simulated pick benchmark (PickSpec):
parsed once at the boundary, the one description that reaches every worker (docs/planning.md, docs/picks.md)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from onepiece_dist.errors import SpecError
from onepiece_dist.specs.frozen import Frozen
from onepiece_dist.specs.job import (
    GripperSpec,
    JobSpec,
    SamplerSpec,
    SimSpec,
    VoxelSpec,
    describe_validation_error,
    gripper_fields,
)


class PlanSpec(Frozen):
    """Grasps planned on one observed cloud: candidates sampled on it (GPD-style), cropped as the training crops
    are, scored by the network, ranked with pose-distance non-maximum suppression."""

    candidates: int = Field(500, ge=1, le=100_000, description="Candidate poses sampled on the cloud (at most).")
    orientations: int = Field(8, ge=1, le=64, description="Approach directions turned about each sampled point's "
                              "curvature axis, over (-90, 90) degrees from straight at the surface.")
    downsample: float = Field(0.003, ge=0, le=0.05, description="Voxel edge (m) the cloud is thinned to before "
                              "sampling (0 keeps every point).")
    min_points: int = Field(10, ge=1, le=10_000, description="Observed points a candidate's closing region must "
                            "hold (PointNetGPD keeps those with more than 10).")
    support_plane: Literal["auto", "none"] = Field("auto", description="Find the dominant plane (a table) by "
                                                   "RANSAC, crop without it and keep the gripper above it; none: "
                                                   "the cloud is the object alone.")
    table_clearance: float = Field(0.008, ge=0, le=0.05, description="Height (m) every corner of the open gripper "
                                   "keeps above the support plane: a sampled hand is pushed in only as deep as it "
                                   "allows (8 mm: kept by the pick benchmark over 2 mm, docs/picks.md).")
    top_k: int = Field(10, ge=1, le=1000, description="Grasps returned after non-maximum suppression.")
    nms_distance: float = Field(0.01, ge=0, le=1, description="Grasps whose closing centres are nearer (m) ...")
    nms_angle_deg: float = Field(30.0, ge=0, le=180, description="... and whose axes differ by less (degrees) than "
                                 "a better one are suppressed.")
    batch_size: int | None = Field(None, ge=1, le=65_536, description="Crops scored per network call; default 16 "
                                   "on a CPU (the fastest measured: a batch stays in the cache), 512 on a GPU.")
    device: Literal["auto", "cpu", "cuda"] = Field("auto", description="Where the network scores: a CUDA GPU when "
                                                   "there is one (auto), else the CPU.")
    seed: int = Field(0, ge=0, lt=2**63, description="Seed of the sampling and of the crops' resampling.")
    score_draws: int = Field(1, ge=1, le=16, description="Draws of each of the 32 best-scored candidates' crop "
                             "points scored and averaged (plan.redraw: a crop holds a random subset of the points "
                             "inside the closing region, so one draw's score moves with it); 1: one draw.")
    top_down: bool = Field(True, description="Also propose the three top-down grasps across the object's narrow "
                           "horizontal axis (the top-down baseline's), cropped and checked as the sampled ones (kept "
                           "by the pick trials: docs/picks.md); in pick labels without a checkpoint they are always "
                           "among a view's executed candidates.")
    check_first: int = Field(3, ge=0, le=50, description="The first this many ranked grasps executed by the pick "
                             "protocol on the shape the view implies (check_shape, in a simulated world of its own: "
                             "picks.shape_check) and reordered by how often they held, the network's order on ties "
                             "(3: kept by the pick benchmark, docs/picks.md); 0: the network's order alone, as a "
                             "planner without a simulator must. Needs a support plane (else the order stands).")
    check_draws: int = Field(4, ge=1, le=32, description="Executions of each checked grasp, each with the "
                             "protocol's pose and friction noise (4 choose as well as 8 or 16: docs/picks.md).")
    check_more: int = Field(0, ge=0, le=50, description="Where none of the first check_first grasps held every "
                            "draw, the next ones checked in rank order, up to this many more, until one does; all "
                            "checked are then reordered as the first are. 0: the first check_first alone.")
    check_density: float | None = Field(None, gt=10, le=20_000, description="Density (kg/m^3) of the shape "
                                        "checked on; None: the pick protocol's. A view's hull fills what is "
                                        "hollow: a mug's hull weighs about 4 times the mug at one density.")
    check_top_down: bool = Field(False, description="Also check the best-scored top-down grasp (top_down) beside "
                                 "the first check_first, placed first only where it held more often than each.")
    carry: bool = Field(False, description="Where no network ships for the gripper and no checkpoint is given, plan "
                        "with the default job's network carried to it (its crops cut in that network's closing "
                        "region, which the gripper's must hold; plan.shipped.planning_network); else such a gripper "
                        "is refused. Carried, it picked about as the preset hands' own networks, and below top-down "
                        "with the Franka Panda read from its URDF (docs/picks.md).")
    check_shape: Literal["hull", "carved", "mirrored"] = Field(
        "hull", description="The shape checked on: the object's observed points and their shadows on the support "
        "plane as one convex hull; that hull less every voxel the camera saw through (carved: an opening it looked "
        "into stays open; needs the camera's position, else the hull); or the hull of the points and their half "
        "turn about the vertical axis of the circle that best fits their footprint (mirrored: a symmetric object's "
        "far side).")
    target: tuple[float, float, float] | None = Field(None, description="A point on the object to pick (m, in the "
                                                      "frame the plan is returned in): only grasps that close on the "
                                                      "object told apart nearest it are planned (refused where none "
                                                      "lies within 5 cm).")
    denoise: Literal["auto", "none"] = Field("auto", description="Take a depth camera's noise out of the view "
                                             "first (core.cloud.denoise): where the points under the support "
                                             "plane show a deviation above 0.5 mm, the table takes every point "
                                             "within 3 deviations of it and each object point moves onto the "
                                             "plane of its 16 nearest; an exact view is left as it is. none: never.")
    drop_flying: float = Field(0.0, ge=0, le=0.05, description="Drop a depth image's flying pixels before it is "
                               "back-projected (core.cloud.flying): each pixel more than this (m) inside its "
                               "neighbours' depths, along rows or columns, that fits neither neighbouring surface's "
                               "continuation within it. 0 keeps every pixel; 0.005 is the measured setting "
                               "(docs/picks.md). A depth image only: a point cloud has no pixel neighbours.")
    objects_apart: bool = Field(True, description="Tell the view's objects apart (points whose 1 cm cells touch "
                                "are one object: core.cloud.objects): each gets its own top-down grasps, a grasp's "
                                "context reads the centre of the object it closes on and the check stands that "
                                "object's shape. False: the whole cloud above the plane is one object.")


class CameraSpec(Frozen):
    """Where the pick benchmark's depth camera looks from: a seeded pose per view on a sphere around the object."""

    distance: tuple[float, float] = Field((0.5, 0.8), description="Camera distance from the object (m), drawn "
                                          "uniformly.")
    elevation_deg: tuple[float, float] = Field((30.0, 70.0), description="Elevation above the table (degrees), "
                                               "drawn uniformly; the azimuth is uniform.")
    image_size: int = Field(320, ge=32, le=2048, description="Square depth image size (pixels).")
    fov_deg: float = Field(45.0, gt=1, lt=150, description="Vertical field of view (degrees).")
    depth_noise: float = Field(0.0, ge=0, le=0.05, description="Gaussian depth noise (m) added per pixel.")
    flying_pixels: float = Field(0.0, ge=0, le=1, description="Share of the pixels at a depth edge (a neighbour "
                                 "2 cm nearer or further) that mix both depths, as a depth camera's flying pixels.")

    @model_validator(mode="after")
    def _ranges_ordered(self) -> CameraSpec:
        for name in ("distance", "elevation_deg"):
            low, high = getattr(self, name)
            if not 0 < low <= high:
                raise ValueError(f"camera.{name}={(low, high)} must satisfy 0 < low <= high")
        if self.elevation_deg[1] > 90:
            raise ValueError(f"camera.elevation_deg={self.elevation_deg}: at most 90 (straight down)")
        return self


PICK_SIM = SimSpec(label_trials=4, success="every_trial")
METHODS = ("network", "random", "analytic", "top_down", "network_full_mesh", "random_full_mesh", "oracle")
Method = Literal["network", "random", "analytic", "top_down", "network_full_mesh", "random_full_mesh", "oracle"]
CLUTTER_METHODS = ("network", "random", "analytic", "top_down", "oracle")  # full-mesh ones need one object's mesh


class PickSpec(Frozen):
    """The simulated pick benchmark (docs/picks.md): each object settled on a table, seen by one depth camera from
    ``views`` seeded poses; the planner's best grasp executed by the label protocol, up to ``attempts`` tries."""

    objects: str = Field("pybullet:random_urdfs[500:508]", description="Held-out objects (a source as a job's).")
    units: Literal["m", "cm", "mm"] = Field("m", description="Units of the objects' mesh and URDF files (a "
                                           "folder's objects.yaml may say otherwise for its own).")
    scale: float = Field(1.0, gt=0, le=1000, description="A further scale of those files (after units).")
    checkpoint: str | None = Field(None, description="The network's checkpoint (best.pt of a train stage); none: "
                                   "the network shipped for the gripper (onepiece_dist/plan/networks/), or the "
                                   "default job's carried to a gripper none ships for (plan.shipped).")
    carried: bool = Field(False, description="The checkpoint was trained for another gripper: its grasps are "
                          "planned for this gripper and its crops cut in the checkpoint's own closing region (set "
                          "where the default job's network is carried; docs/picks.md says what that picks).")
    output: str = Field("onepiece-out/picks", description="Folder for picks.json and the pictures.")
    views: int = Field(3, ge=1, le=64, description="Camera poses per object.")
    first_view: int = Field(0, ge=0, le=4096, description="The first view's index: views first_view to first_view "
                            "+ views - 1, each with draws of its own, so a run at first_view N adds views to one "
                            "of N views without repeating them.")
    attempts: int = Field(3, ge=1, le=20, description="k: the ranked grasps tried per view, one after another.")
    seed: int = Field(0, ge=0, lt=2**63, description="Seed of the drops, the camera poses and the planning.")
    methods: tuple[Method, ...] = Field(
        METHODS, min_length=1, description="What chooses the grasp: the network on the view, a random collision-free "
        "candidate, the analytic antipodal score on the view's cloud, straight down across the cloud's narrow "
        "horizontal axis (top_down), the network and a random choice among candidates sampled on the full mesh "
        "(what held-out top-1 measures), and the oracle: every candidate of the view executed (the pool's ceiling).")
    oracle_candidates: int = Field(1000, ge=1, le=100_000, description="The oracle executes at most this many of "
                                   "a view's candidates.")
    mesh_candidates: int = Field(200, ge=1, le=100_000, description="Candidates sampled on the full mesh "
                                 "(network_full_mesh).")
    pictures: int = Field(4, ge=0, le=64, description="Views drawn as PNG with their planned grasps.")
    workers: int | None = Field(None, ge=1, description="Worker actors on Ray (default: the cluster's CPUs).")
    gripper: GripperSpec | None = Field(None, description="The gripper; default: the checkpoint's (the default "
                                        "job's without a checkpoint).")
    plan: PlanSpec = PlanSpec()
    camera: CameraSpec = CameraSpec()
    sim: SimSpec = Field(PICK_SIM, description="The label protocol every pick is executed with (K trials, "
                         "every_trial: a pick succeeds when all K hold).")
    sampler: SamplerSpec = SamplerSpec()
    max_file_bytes: int = Field(64 * 2**20, gt=0, description="Mesh and URDF files larger than this are rejected.")
    clutter: int = Field(1, ge=1, le=8, description="Objects on the table together in a view: 1, each object alone; "
                         "N, each object of the source with the next N-1 (wrapping round), each dropped 1-5 cm "
                         "beyond those already there, one camera aimed at their middle; a grasp picks the object it "
                         "closes on (docs/picks.md). With N > 1 the methods default to all but the full-mesh ones, "
                         "which need one object's mesh.")
    pile: bool = Field(False, description="With clutter N > 1: each next object dropped onto those already there "
                       "(its middle within 3 cm of theirs, a pile that touches and leans) instead of 1-5 cm beside "
                       "them.")

    @field_validator("gripper", mode="before")
    @classmethod
    def _preset(cls, value: Any) -> Any:
        return gripper_fields(value)

    @model_validator(mode="before")
    @classmethod
    def _clutter_methods(cls, data: Any) -> Any:
        if isinstance(data, dict) and int(data.get("clutter") or 1) > 1 and "methods" not in data:
            return {**data, "methods": CLUTTER_METHODS}
        return data

    @model_validator(mode="after")
    def _clutter_has_no_full_mesh(self) -> PickSpec:
        wrong = [m for m in self.methods if self.clutter > 1 and m not in CLUTTER_METHODS]
        if wrong:
            raise ValueError(f"methods {', '.join(wrong)} sample one object's full mesh and have no meaning with "
                             f"clutter {self.clutter}: leave them out (clutter runs {', '.join(CLUTTER_METHODS)})")
        if self.pile and self.clutter < 2:
            raise ValueError("pile drops each next object onto those there: it needs clutter 2 or more")
        return self

    @property
    def view_indices(self) -> range:
        """The indices of the views each object is seen at: first_view to first_view + views - 1."""
        return range(self.first_view, self.first_view + self.views)

    def object_job(self, gripper: GripperSpec, voxel: VoxelSpec) -> JobSpec:
        """The job-shaped spec the object loader and the full-mesh sampler read (file limits, extents, physics)."""
        return JobSpec(objects=self.objects, gripper=gripper, voxel=voxel, sampler=self.sampler, sim=self.sim,
                       max_file_bytes=self.max_file_bytes, seed=self.seed, units=self.units, scale=self.scale)


def parse_pick_spec(data: dict[str, Any], source: str = "<pick spec>") -> PickSpec:
    """Validate a mapping into a :class:`PickSpec`; errors name the field, the value and the rule."""
    try:
        return PickSpec.model_validate(data)
    except ValidationError as err:
        raise SpecError(describe_validation_error(err, source, "pick spec")) \
            from None


def parse_pick_label_spec(data: dict[str, Any], source: str = "<pick label spec>") -> PickLabelSpec:
    """Validate a mapping into a :class:`PickLabelSpec`; errors name the field, the value and the rule."""
    try:
        return PickLabelSpec.model_validate(data)
    except ValidationError as err:
        raise SpecError(describe_validation_error(err, source, "pick label spec")) from None


# pick-labels' default objects: at the same label count the Franka hand's network picks more of the household
# meshes on these than on pybullet:random_urdfs[0:64], the box gripper's as many (docs/picks.md, "A network made
# by the two commands").
PLANNER_CLEARANCE_BEFORE = 0.002  # m: the planner's fixed table clearance before PlanSpec.table_clearance existed
PICK_LABEL_OBJECTS = "pybullet:random_urdfs[0:32]+shapes:groceries[0:16]+shapes:vessels[0:16]"


class PickLabelSpec(Frozen):
    """Labels made where the network is used (issue 55): each training object settled on the table and seen from
    ``views`` seeded cameras exactly as the pick benchmark sees it, the planner's candidates proposed on the view
    and each executed by the pick protocol (the same hand, table and trials the benchmark judges with). Each label
    keeps the candidate's crop of the view and its context (gravity and the object's centre in the gripper frame)."""

    objects: str = Field(PICK_LABEL_OBJECTS, description="Training objects (a source as a job's). The default: "
                         "32 of pybullet_data's random objects and 32 seeded household-sized shapes (objects.shapes).")
    units: Literal["m", "cm", "mm"] = Field("m", description="Units of the objects' mesh and URDF files (a "
                                           "folder's objects.yaml may say otherwise for its own).")
    scale: float = Field(1.0, gt=0, le=1000, description="A further scale of those files (after units).")
    output: str = Field("onepiece-out/pick_labels", description="Folder of the labels (pick_labels.zarr).")
    views: int = Field(8, ge=1, le=256, description="Camera poses per object.")
    per_view: int = Field(16, ge=1, le=10_000, description="Candidates executed per view (a seeded subset; 16 "
                          "made the shipped networks' labels).")
    checkpoint: str | None = Field(None, description="A network whose best-scored candidates of each view are "
                                   "executed first (its own first choices, right or wrong: on-policy labels); the "
                                   "rest of per_view at random. None: all at random.")
    top_share: float = Field(0.5, ge=0, le=1, description="With a checkpoint: the share of per_view taken from the "
                             "network's best-scored candidates.")
    seed: int = Field(0, ge=0, lt=2**63, description="Seed of the drops, cameras, planning and executions.")
    gripper: GripperSpec = GripperSpec()
    voxel: VoxelSpec = VoxelSpec()
    points_per_grasp: int = Field(256, ge=1, le=4096, description="Gripper-frame points kept per crop.")
    plan: PlanSpec = PlanSpec()
    camera: CameraSpec = CameraSpec()
    sim: SimSpec = Field(PICK_SIM, description="The pick protocol every candidate is executed with.")
    sampler: SamplerSpec = SamplerSpec()
    max_file_bytes: int = Field(64 * 2**20, gt=0, description="Mesh and URDF files larger than this are rejected.")
    workers: int | None = Field(None, ge=1, description="Worker actors on Ray (default: the cluster's CPUs).")

    @field_validator("gripper", mode="before")
    @classmethod
    def _preset(cls, value: Any) -> Any:
        return gripper_fields(value)

    def object_job(self) -> JobSpec:
        """The job-shaped spec the object loader reads (file limits, extents, physics)."""
        return JobSpec(objects=self.objects, gripper=self.gripper, voxel=self.voxel, sampler=self.sampler,
                       sim=self.sim, max_file_bytes=self.max_file_bytes, seed=self.seed, units=self.units,
                       scale=self.scale)

    @classmethod
    def stored(cls, data: dict[str, Any]) -> PickLabelSpec:
        """The spec a label store kept (its attrs), read as it was made, never as today's defaults would: stores
        written before ``plan.top_down`` existed executed no top-down grasps (its absence reads False), and those
        written before ``plan.table_clearance`` existed sampled their hands 2 mm over the table (its absence reads
        PLANNER_CLEARANCE_BEFORE), not today's 8 mm."""
        before = {"top_down": False, "table_clearance": PLANNER_CLEARANCE_BEFORE}
        return cls.model_validate({**data, "plan": {**before, **data.get("plan", {})}})
