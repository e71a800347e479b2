"""Frozen, validated specs: the one description of a job that flows from the CLI or API to every worker.

Parsed once at the boundary (:func:`load_job_spec`, :func:`parse_job_spec`); workers only read attributes.
Lengths are metres, forces newtons, angles radians.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from onepiece_dist.errors import SpecError
from onepiece_dist.gripper.presets import gripper_fields
from onepiece_dist.specs.frozen import Frozen
from onepiece_dist.specs.labels import AdaptiveSpec, BudgetSpec, EvaluateSpec

RESULTS_REVISION = 4  # bump when code changes what an extraction produces (2: one rigid body, coupled fingers;
#                      3: parts keep the object's surface points and convex pieces, for patches; 4: fc_epsilon's
#                      hull without qhull's pre-merging, the last bits of a quarter of the epsilons)

STAGES = ("ingest", "extract", "dedup", "assemble", "label", "train", "evaluate")
Stage = Literal["ingest", "extract", "dedup", "assemble", "label", "train", "evaluate"]


class GripperSpec(Frozen):
    """Parallel-jaw gripper, close to a Franka Panda hand.

    Gripper frame (see docs/gripper_frame.md): u = approach (palm to fingertips), v = closing axis,
    t = finger height, origin at the palm centre. Closing region: 0 <= u < closing_depth,
    |v| < closing_width / 2, |t| < closing_height / 2.
    """

    name: str = Field("onepiece_box", description="What the gripper is called: a preset's name (franka_panda, "
                      "robotiq_2f_85, robotiq_2f_140) or yours; datasets and exports name it.")
    max_opening: float = Field(0.08, gt=0, le=0.5, description="Largest distance between the finger pads (m).")
    finger_length: float = Field(0.04, gt=0, le=0.3, description="Finger extent along u (m).")
    finger_thickness: float = Field(0.01, gt=0, le=0.1, description="Finger extent along v (m).")
    finger_height: float = Field(0.02, gt=0, le=0.2, description="Finger extent along t (m).")
    palm_depth: float = Field(0.02, gt=0, le=0.3, description="Palm extent along -u behind the origin (m).")
    palm_height: float = Field(0.06, gt=0, le=0.3, description="Palm extent along t (m).")
    closing_depth: float = Field(0.04, gt=0, description="Closing region extent along u (m).")
    closing_width: float = Field(0.08, gt=0, description="Closing region extent along v (m).")
    closing_height: float = Field(0.02, gt=0, description="Closing region extent along t (m).")
    friction: float = Field(0.4, gt=0, le=5, description="Finger pad friction coefficient: rubber pads on "
                            "smooth household surfaces (plastic, glass, glazed ceramic) are about 0.4 to 0.6; "
                            "0.4 makes labels discriminate (docs/trials.md).")
    closing_force: float = Field(40.0, gt=0, le=1000, description="Force limit of each finger (N).")
    finger_mass: float = Field(0.02, gt=0, description="Mass of one finger (kg).")

    @model_validator(mode="after")
    def _region_fits_fingers(self) -> GripperSpec:
        if self.closing_width > self.max_opening + 1e-12:
            raise ValueError(
                f"closing_width={self.closing_width} must not exceed max_opening={self.max_opening}"
            )
        if self.closing_depth > self.finger_length + 1e-12:
            raise ValueError(
                f"closing_depth={self.closing_depth} must not exceed finger_length={self.finger_length}"
            )
        return self


class VoxelSpec(Frozen):
    """Voxel grid over the closing region; ``resolution`` must divide each region extent."""

    resolution: float = Field(0.01, gt=0, le=0.1, description="Voxel edge length (m).")
    canonical: bool = Field(False, description="Map each code to its canonical form under the gripper's "
                            "180-degree symmetry about the approach axis.")

    def grid_shape(self, gripper: GripperSpec) -> tuple[int, int, int]:
        """(a, b, c) voxels along (u, v, t) for this gripper's closing region."""
        extents = {"closing_depth": gripper.closing_depth, "closing_width": gripper.closing_width,
                   "closing_height": gripper.closing_height}
        shape = []
        for name, extent in extents.items():
            n = extent / self.resolution
            if abs(n - round(n)) > 1e-6 or round(n) < 1:
                raise SpecError(f"voxel.resolution={self.resolution} must divide gripper.{name}={extent} "
                                f"into a whole number of voxels (got {n:.4f})")
            shape.append(int(round(n)))
        return (shape[0], shape[1], shape[2])


class SamplerSpec(Frozen):
    """Grasp candidate sampling."""

    method: Literal["antipodal", "normal"] = Field("antipodal",
        description="Candidate sampler: antipodal point pairs, or approach along the surface normal.")
    surface_points: int = Field(10000, ge=500, le=2_000_000, description="Dense surface points per object.")
    approach_angles: int = Field(8, ge=1, le=64, description="Approach directions tried around each grasp axis.")
    friction_cone: float = Field(0.5, gt=0, le=3, description="Friction coefficient of the antipodal cone test.")
    min_width: float = Field(0.002, ge=0, description="Narrowest accepted contact distance (m).")
    depth_range: tuple[float, float] = Field((0.3, 0.9), description="Contact depth along u, as fractions "
                                             "of closing_depth, sampled uniformly.")
    max_object_extent: float = Field(1.0, gt=0, description="Objects with a larger bounding-box diagonal "
                                     "are rejected (m; catches wrong units).")

    @model_validator(mode="after")
    def _depth_range_ordered(self) -> SamplerSpec:
        lo, hi = self.depth_range
        if not 0 <= lo <= hi <= 1:
            raise ValueError(f"depth_range={self.depth_range} must satisfy 0 <= low <= high <= 1")
        return self


class SimSpec(Frozen):
    """Physics of the extract stage (docs/trials.md)."""

    physics: bool = Field(True, description="Simulate each candidate (extract protocol) and crop at the settled "
                          "pose; false crops at the static candidate pose.")
    collision: Literal["vhacd", "coacd", "hull"] = Field("vhacd", description="Object collision geometry: "
        "convex decomposition by VHACD (default) or CoACD (extra 'decompose'; docs/decomposition.md), or the "
        "plain convex hull.")
    density: float = Field(400.0, gt=10, le=20_000, description="Object density (kg/m^3) over the mesh's enclosed "
                           "volume; mass clipped to 0.05-2 kg (docs/trials.md).")
    label: bool = Field(False, description="Also lift and shake each grasp and store success labels.")
    label_trials: int = Field(1, ge=1, le=32, description="K: label trials per grasp (the nominal one plus K-1 "
                              "with pose and friction noise); quality = success fraction.")
    success: Literal["nominal", "every_trial"] = Field("nominal", description="Binary label (grasps/success): "
        "the nominal trial held, or every one of the K trials held (a robust label, as Dex-Net thresholds robust "
        "quality; docs/trials.md). The same with K = 1.")
    load: Literal["object", "grasp"] = Field("object", description="What the label trials lift and shake: the "
        "object itself (its mass at its centre of mass), or a payload of load_mass kg centred at the grasp centre "
        "(the closing region's centre), so the label depends on the contacts of the shape in the gripper and not "
        "on mass outside it, as a contact-based label (force closure, wrench resistance) does (docs/trials.md).")
    load_mass: float = Field(0.5, gt=0, le=10, description="Payload (kg) of the label trials with load='grasp'.")
    pose_noise: float = Field(0.003, ge=0, le=0.05, description="Translation noise of perturbed trials (m).")
    rotation_noise: float = Field(0.05, ge=0, le=1, description="Rotation noise of perturbed trials (rad).")
    friction_noise: float = Field(0.2, ge=0, le=1, description="Relative friction noise of perturbed trials.")
    perturbations_per_patch: int = Field(4, ge=0, le=64, description="Label stage on the one object: perturbed "
                                         "poses labelled around each patch's placement, besides the placement.")
    points_per_grasp: int = Field(750, ge=0, le=4096, description="Gripper-frame points stored per grasp "
                                  "(resampled with replacement; 0 stores none).")
    transfer_codes: int = Field(200, ge=0, le=100_000, description="Label stage: unique codes (with two or more "
                                "grasps, a seeded sample) whose source grasps are also labelled on their own objects, "
                                "to measure how far a label transfers (docs/assembly.md); 0 skips it.")
    transfer_grasps: int = Field(5, ge=2, le=64, description="Source grasps labelled per sampled code (its "
                                 "representative and the first others).")

    def label_trials_per_patch(self) -> int:
        """Label trials around one patch of the one object: its placement and each perturbed pose, K each."""
        return (1 + self.perturbations_per_patch) * self.label_trials


class ViewSpec(Frozen):
    """Depth views rendered in pybullet and partial-view crops (docs/views.md)."""

    count: int = Field(0, ge=0, le=256, description="Depth views per object from cameras spread on a sphere "
                       "around it, back-projected and stored under views/ (0 = none).")
    image_size: int = Field(256, ge=16, le=2048, description="Square depth image size (pixels).")
    fov_deg: float = Field(45.0, gt=1, lt=150, description="Vertical field of view (degrees).")
    crop: Literal["full", "partial"] = Field("full", description="Crop each grasp's points and code from the "
                                             "full surface, or from the depth view of the camera whose viewing "
                                             "direction is nearest the grasp's approach (what a robot sees).")
    sampling: Literal["mesh", "view"] = Field("mesh", description="Where candidates are sampled: on the mesh "
                                              "(antipodal or normal sampler), or as the planner samples a camera's "
                                              "cloud (docs/planning.md): on each view's cloud, cropped from that "
                                              "view, the points (grasps/points) at the candidate pose, before the "
                                              "fingers close, and candidates whose fingers close on nothing kept "
                                              "(a success never), so training crops are the kind `onepiece grasp` "
                                              "scores (needs crop: partial).")
    distance: float | None = Field(None, gt=0, le=5, description="Camera distance from the object's centre (m); "
                                   "default: as near as frames the whole object. The pick benchmark's camera is "
                                   "0.5-0.8 m away: 0.65 with image_size 320 gives its point density.")

    @model_validator(mode="after")
    def _partial_needs_views(self) -> ViewSpec:
        if self.crop == "partial" and self.count < 1:
            raise ValueError(f"crop='partial' needs depth views: count={self.count} must be at least 1")
        if self.sampling == "view" and self.crop != "partial":
            raise ValueError("sampling='view' crops each candidate from the view it was sampled on: set crop: "
                             "partial (and count >= 1)")
        return self


class ClosureSpec(Frozen):
    """Analytic scores of each grasp at its settled pose (core.closure, docs/trials.md Analytic labels): force
    closure's smallest friction level and the Ferrari-Canny epsilon, on the source meshes and on the one object's
    patches."""

    enabled: bool = Field(False, description="Score every extracted and every labelled grasp: grasps/fc_mu, "
                          "fc_epsilon, fc_contacts (and the same in assembled/grasps/).")
    levels: tuple[float, ...] = Field((1.2, 1.0, 0.8, 0.6, 0.4, 0.2), min_length=1, description="Friction levels "
                                      "swept for force closure (graspnetAPI's; PointNetGPD's full sweep is 2.0, "
                                      "1.6, 1.2, 0.8, 0.5, 0.45, 0.4); fc_mu is the smallest that holds, +inf none.")
    epsilon_mu: float = Field(0.5, gt=0, le=5, description="Friction of the Ferrari-Canny epsilon.")
    facets: int = Field(8, ge=3, le=64, description="Edges of each friction cone's polyhedral approximation.")
    soft: bool = Field(True, description="Soft fingers (torsional friction); two point contacts have epsilon 0.")
    label: Literal["physics", "force_closure", "both"] = Field("physics", description="What the binary label "
        "(success, the training target) is: the physics trials' outcome, force closure at good_mu or better, or "
        "both at once. Unless physics, the trials' outcome is kept as physics_success; with force_closure and "
        "sim.label false, the source objects are labelled without lifting anything.")
    good_mu: float = Field(0.4, gt=0, le=10, description="A grasp is good by force closure when fc_mu <= good_mu "
                           "(PointNetGPD: 0.5; graspnetAPI's sweep has 0.4).")

    @model_validator(mode="after")
    def _levels_and_label(self) -> ClosureSpec:
        if any(not 0 < mu <= 10 for mu in self.levels):
            raise ValueError(f"closure.levels={self.levels}: every level must lie in (0, 10]")
        if self.label != "physics" and not self.enabled:
            raise ValueError(f"closure.label={self.label!r} needs the scores: set closure.enabled: true")
        return self



class TrainSpec(Frozen):
    """The train stage: which network on which labelled grasps."""

    model: Literal["pointnet", "voxel"] = Field("pointnet",
        description="Grasp network: PointNet on the crop's points, or a 3D CNN on its voxel code.")
    data: Literal["assembled", "all", "budget"] = Field("assembled", description="Labelled grasps of the one "
                                                        "object (assembled/grasps), of every object (grasps, needs "
                                                        "sim.label) or a budget's or adaptive rounds' "
                                                        "(labelled/grasps).")
    epochs: int = Field(10, ge=1, le=1000, description="Passes over the training split.")
    batch_size: int = Field(64, ge=2, le=4096, description="Grasps per gradient step.")
    learning_rate: float = Field(1e-3, gt=0, le=1, description="Adam learning rate.")
    validation: float = Field(0.2, gt=0, lt=1, description="Share of objects (or patches) held out.")
    patience: int = Field(5, ge=1, description="Epochs without a better validation loss before stopping.")
    device: Literal["auto", "cpu", "cuda"] = Field("auto", description="Where to train and evaluate: 'auto' "
                                                   "takes a CUDA GPU when the trainer has one (on Ray the trainer "
                                                   "actor asks for one when the cluster has GPU nodes), else the "
                                                   "CPU; 'cuda' requires one.")
    precision: Literal["fp32", "bf16"] = Field("fp32", description="bf16 autocast on the training step: faster "
                                               "for the voxel CNN on a GPU, slower for PointNet (measured, "
                                               "docs/performance.md).")
    loader_workers: int = Field(0, ge=0, le=64, description="DataLoader worker processes reading the store.")
    weight_by_count: bool = Field(False, description="On the one object's grasps: weight each grasp's loss by how "
                                  "many extracted grasps its patch's code stands for (unique/count, mean 1). Off by "
                                  "default: on the paper experiment it lowered held-out AP and top-1 "
                                  "(docs/performance.md, What would lift B to R).")


class JobSpec(Frozen):
    """Everything a job needs. Workers receive exactly this object."""

    objects: str = Field("pybullet:named", description="Object source: a built-in set (pybullet:named, "
                         "pybullet:random_urdfs[0:64], primitives, shapes:groceries[0:32]), a folder or a glob.")
    grasps_per_object: int = Field(64, ge=1, le=100_000,
        description="Grasp candidates sampled and simulated per object.")
    seed: int = Field(0, ge=0, lt=2**63,
        description="Random seed; each object's stream derives from it and the object's content.")
    output: str = Field("onepiece-out/dataset.zarr", description="Dataset path (Zarr v3 directory).")
    cache_dir: str | None = Field(None, description="Folder of per-object results shared across jobs; "
                                  "defaults to the dataset's own parts/ folder.")
    decompositions: str | None = Field(None, description="Folder of the objects' convex decompositions, shared by "
                                       "the jobs naming it. Default: a local run's (API, CLI) is this user's cache "
                                       "folder, a cluster job's the parts folder's collision/.")
    stages: tuple[Stage, ...] = Field(("ingest", "extract", "dedup", "assemble", "label", "train", "evaluate"),
                                      description="Stages to run: 'assemble' builds the one object from the unique "
                                      "codes, 'label' labels grasps on it, 'train' fits the grasp network, "
                                      "'evaluate' scores it on the held-out objects of 'evaluate'.")
    similar_radius: int = Field(0, ge=0, le=64, description="Merge codes that differ in at most this many voxels "
                                "(0 = exact dedup only); unique/ then holds one representative per cluster.")
    max_file_bytes: int = Field(64 * 2**20, gt=0, description="Mesh and URDF files larger than this are rejected.")
    units: Literal["m", "cm", "mm"] = Field("m", description="Units of the mesh and URDF files the objects source "
                                           "names (pybullet's built-in sets know theirs); a file clearly in other "
                                           "units is refused with the units that fit, never rescaled silently.")
    scale: float = Field(1.0, gt=0, le=1000, description="A further scale of those files (after units).")
    keep_all_points: bool = Field(False, description="Store every extracted grasp's points in grasps/points. By "
                                  "default a job that labels on the one object (stage 'label', sim.label false) "
                                  "keeps points only for the representatives (unique/points) and the labelled "
                                  "grasps (assembled/grasps/points): per extracted grasp a few hundred bytes, "
                                  "not 4.5 kB.")
    gripper: GripperSpec = Field(GripperSpec(), description="The gripper: its fields, or a preset's name (panda, "
                                 "robotiq_2f85, robotiq_2f140; onepiece_dist/gripper/presets.py), or a mapping "
                                 "with preset: NAME, or urdf: PATH (read from its finger links), and fields that "
                                 "differ from it.")
    voxel: VoxelSpec = VoxelSpec()
    sampler: SamplerSpec = SamplerSpec()
    sim: SimSpec = SimSpec()
    views: ViewSpec = ViewSpec()
    closure: ClosureSpec = ClosureSpec()
    train: TrainSpec = TrainSpec()
    evaluate: EvaluateSpec = EvaluateSpec()
    budget: BudgetSpec = BudgetSpec()
    adaptive: AdaptiveSpec = AdaptiveSpec()

    @field_validator("gripper", mode="before")
    @classmethod
    def _preset(cls, value: Any) -> Any:
        return gripper_fields(value)

    @model_validator(mode="after")
    def _adaptive_labels_in_rounds(self) -> JobSpec:
        if not self.adaptive.enabled:
            return self
        if self.budget.enabled:
            raise ValueError("adaptive: its budget is adaptive.limit; leave budget.count and budget.fraction unset")
        if self.runs("assemble") or self.sim.label or not (self.runs("label") and self.runs("train")):
            raise ValueError("adaptive labels candidates on their own objects in rounds of the 'label' stage, the "
                             "trainer choosing each round: it needs 'label' and 'train' in stages, no 'assemble' "
                             "(the one object) and sim.label false")
        if self.train.data != "budget":
            raise ValueError("adaptive: the train stage fits the rounds' labels (labelled/grasps): set "
                             "train.data: budget")
        return self

    @model_validator(mode="after")
    def _budget_labels_sources(self) -> JobSpec:
        if self.budget.enabled and (self.runs("assemble") or self.sim.label or not self.runs("label")):
            raise ValueError("budget labels a subset of the candidates on their own objects in the 'label' stage: "
                             "it needs 'label' in stages, no 'assemble' (the one object) and sim.label false "
                             "(every candidate labelled)")
        return self

    @model_validator(mode="after")
    def _grid_is_whole(self) -> JobSpec:
        try:
            self.voxel.grid_shape(self.gripper)
        except SpecError as err:
            raise ValueError(str(err)) from None
        return self

    def grid_shape(self) -> tuple[int, int, int]:
        return self.voxel.grid_shape(self.gripper)

    def unit_scale(self) -> float:
        """What the source's file coordinates are multiplied by to be metres."""
        return {"m": 1.0, "cm": 0.01, "mm": 0.001}[self.units] * self.scale

    def runs(self, stage: Stage) -> bool:
        """Whether this job runs ``stage``."""
        return stage in self.stages

    def parts_folder(self) -> str:
        """Where per-object parts live: ``cache_dir`` (shared across jobs) or ``<output>.parts`` beside it."""
        return self.cache_dir or f"{Path(self.output)}.parts"

    def decompositions_folder(self) -> Path:
        """Where the objects' convex decompositions are kept: ``decompositions``, or the parts folder's."""
        return Path(self.decompositions or Path(self.parts_folder()) / "collision")

    def code_bytes(self) -> int:
        a, b, c = self.grid_shape()
        return math.ceil(a * b * c / 8)

    def result_key(self) -> str:
        """Hash of every field that changes an object's extraction result (not output paths), and of
        :data:`RESULTS_REVISION`, so parts cached by older code are not reused."""
        relevant = self.model_dump(mode="json", include={"grasps_per_object", "seed", "gripper", "voxel",
                                                         "sampler", "sim", "views", "closure"})
        relevant["results_revision"] = RESULTS_REVISION
        return hashlib.blake2b(json.dumps(relevant, sort_keys=True).encode(), digest_size=8).hexdigest()


def default_job_id(spec: JobSpec) -> str:
    """A job id derived from the whole spec: submitting the same spec twice names the same job."""
    digest = hashlib.blake2b(spec.model_dump_json().encode(), digest_size=6).hexdigest()
    return f"job-{digest}"


def parse_job_spec(data: dict[str, Any], source: str = "<spec>") -> JobSpec:
    """Validate a mapping into a :class:`JobSpec`; errors name the field, the value and the rule."""
    try:
        return JobSpec.model_validate(data)
    except ValidationError as err:
        raise SpecError(describe_validation_error(err, source)) from None


def describe_validation_error(err: ValidationError, source: str, what: str = "job spec") -> str:
    """``source``'s errors, one line per field: its path, the value given and what is wrong (``what``: the kind
    of file, as the user calls it)."""
    lines = [f"{source}: invalid {what}"]
    for item in err.errors():
        field = ".".join(str(p) for p in item["loc"]) or "<root>"
        value = item.get("input")
        shown = json.dumps(value, default=str)[:80] if not isinstance(value, dict) else "{...}"
        lines.append(f"  {field} = {shown}: {item['msg']}")
    return "\n".join(lines)


def load_job_spec(path: str | Path, overrides: dict[str, Any] | None = None) -> JobSpec:
    """Load a YAML or JSON spec file, apply ``overrides`` (top-level fields), and validate."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as err:
        raise SpecError(f"{path}: cannot read spec: {err.strerror}") from None
    data = _parse_mapping(text, path)
    data.update(overrides or {})
    return parse_job_spec(data, str(path))


def _parse_mapping(text: str, path: Path) -> dict[str, Any]:
    import yaml

    try:
        data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise SpecError(f"{path}: not valid {'JSON' if path.suffix == '.json' else 'YAML'}: {err}") from None
    if data is not None and not isinstance(data, dict):
        raise SpecError(f"{path}: a spec must be a mapping of fields, got {type(data).__name__}")
    return data or {}
