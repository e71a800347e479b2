"""The frozen description of a study: which objects, which arms, how the networks train and what counts as
"as good as labelling everything". One :class:`StudySpec` flows from the command line or the API to every job and
training run of the study; the decision's targets are its fields, never constants in code.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from onepiece_dist.errors import SpecError
from onepiece_dist.specs.frozen import Frozen
from onepiece_dist.specs.job import GripperSpec, JobSpec, describe_validation_error
from onepiece_dist.specs.labels import RoundsRule


class StudyTraining(Frozen):
    """How every arm's network trains: the same network, the same number of gradient steps, the learning rate its
    own validation split picks (never the held-out objects), several seeds."""

    model: Literal["pointnet", "voxel"] = Field("pointnet", description="Grasp network of every arm.")
    steps: int = Field(500, ge=1, le=1_000_000, description="Gradient steps of every training run.")
    batch_size: int = Field(64, ge=2, le=4096, description="Grasps per gradient step.")
    learning_rates: tuple[float, ...] = Field((3e-4, 1e-3, 3e-3), min_length=1, description="Adam rates tried; "
                                              "each arm's seed-0 run trains at each and the arm keeps the one "
                                              "with the lowest loss on its own validation split.")
    seeds: int = Field(3, ge=1, le=32, description="Training seeds per arm (the intervals average over them).")
    validation: float = Field(0.2, gt=0, lt=1, description="Share of train objects (or patches) held out to pick "
                              "the checkpoint and the learning rate.")
    evaluations: int = Field(10, ge=1, le=1000, description="Validation checks per run; the best is kept.")
    b_weighting: Literal["none", "count", "sqrt"] = Field("none", description="B arms only: each patch's loss "
                                                          "weighed by how many extracted grasps its label stands "
                                                          "for (its code's count), that count's square root, or "
                                                          "not (docs/performance.md, What would lift B to R).")
    device: Literal["auto", "cpu", "cuda"] = Field("auto", description="Where runs train: 'auto' takes a GPU "
                                                   "when the trainer actor has one.")

    @model_validator(mode="after")
    def _positive_rates(self) -> StudyTraining:
        if min(self.learning_rates) <= 0:
            raise ValueError(f"learning_rates={self.learning_rates}: every rate must be positive")
        return self


class StudyAdaptive(RoundsRule):
    """The adaptive arm U (study.adaptive): labels chosen by the network in rounds, among A's candidates."""


class StudyKey(Frozen):
    """A dedup key measured as a lookup (study.keys): occupancy at a resolution, a contact key (the relief under
    each pad, core.contact), or both concatenated."""

    name: str = Field(min_length=1, max_length=80, description="What the page calls it.")
    kind: Literal["occupancy", "contact", "both"]
    resolution: float = Field(0.01, gt=0, le=0.1, description="Occupancy voxel edge (m); it must divide the "
                              "closing region.")
    cell: float = Field(0.01, gt=0, le=0.1, description="Contact: pad cell edge (m).")
    step: float = Field(0.002, gt=0, le=0.1, description="Contact: relief step (m).")
    levels: int = Field(4, ge=1, le=254, description="Contact: relief levels before 'farther'.")
    width_step: float = Field(0.005, gt=0, le=0.1, description="Contact: opening step (m).")

    @model_validator(mode="after")
    def _divides_the_closing_region(self) -> StudyKey:
        from onepiece_dist.core.contact import ContactKeySpec

        g = GripperSpec()  # a study's jobs grip with the default gripper
        region = (g.closing_depth, g.closing_width, g.closing_height)
        if self.kind in ("occupancy", "both") and any(abs(x / self.resolution - round(x / self.resolution)) > 1e-6
                                                      for x in region):
            raise ValueError(f"resolution={self.resolution} does not divide the closing region {region} (m)")
        if self.kind in ("contact", "both"):
            ContactKeySpec(region, self.cell, self.step, self.levels, self.width_step)  # ValueError names the field
        return self


class StudyPicks(Frozen):
    """How picks judge the arms (judge: picks or both): the pick benchmark's views of the held-out objects, each
    network's first choice executed by the study's label protocol (docs/picks.md)."""

    views: int = Field(2, ge=1, le=64, description="Camera poses per held-out object.")
    objects: str | None = Field(None, description="The objects picked (default: the held-out objects).")


class StudyTargets(Frozen):
    """What the report decides with: A's intervals and the cost targets a plan must meet to be called cheap."""

    confidence: float = Field(0.95, gt=0.5, lt=1, description="Level of the bootstrap intervals over held-out "
                              "objects; a plan is as good as A when its mean top-1 and AP lie inside A's "
                              "intervals (or above them).")
    bootstrap_draws: int = Field(2000, ge=100, le=100_000, description="Resamples of the held-out objects for "
                                 "the top-1 interval.")
    ap_draws: int = Field(1000, ge=100, le=100_000, description="Resamples for the AP interval.")
    time_ratio: float = Field(8.0, gt=0, description="Label-time ratio A / plan that counts as cheap (the "
                              "paper: 2 days against about 6 hours).")
    storage_ratio: float = Field(6.3, gt=0, description="Labelled-storage ratio A / plan that counts as cheap "
                                 "(the paper: 43.7 GB against 6.9 GB).")
    adaptive_share: float = Field(0.1, gt=0, le=1, description="The adaptive arm's target: stop inside A's "
                                  "intervals at no more than this share of A's label cost (core-seconds).")


class StudySpec(Frozen):
    """A study: arms A (every candidate labelled on its own object), B (the one object, per similar-shape radius)
    and R (random subsets of A's labels: one per label budget, the learning curve, and one the size of each B arm),
    trained alike and scored on held-out objects whose every candidate is labelled."""

    train: str = Field("pybullet:random_urdfs[0:8]", description="Train objects: a source as in a job.")
    heldout: str = Field("pybullet:random_urdfs[500:508]", description="Held-out objects, never trained on: a "
                         "source as in a job; none may share a mesh (content id) with a train object.")
    grasps_per_object: int = Field(200, ge=2, le=100_000, description="Candidates per train object.")
    heldout_grasps: int = Field(100, ge=2, le=100_000, description="Candidates per held-out object.")
    seed: int = Field(0, ge=0, lt=2**62, description="Seed of the train jobs (held-out: seed + 1), the R subsets "
                      "and the statistics.")
    radii: tuple[int, ...] = Field((0, 1, 2), min_length=1, description="Similar-shape radii of the B arms.")
    static_radii: tuple[int, ...] = Field((), description="Radii of B static arms: the one object from crops at "
                                          "each candidate's pose, with no physics in extraction (the paper's static "
                                          "extraction); none by default.")
    budgets: tuple[float, ...] = Field((0.01, 0.03, 0.1, 0.3), description="R arms: shares of A's labelled "
                                       "candidates, drawn at random (the learning curve); R arms the size of each B "
                                       "arm are added.")
    label_trials: int = Field(4, ge=1, le=32, description="K: label trials per grasp, in every arm.")
    success: Literal["nominal", "every_trial"] = Field("every_trial", description="Binary label: the nominal trial "
                                                       "held, or all K trials held (docs/trials.md).")
    load: Literal["object", "grasp"] = Field("object", description="What the label trials lift: the object, or "
                                             "a payload at the grasp centre (docs/trials.md).")
    load_mass: float = Field(0.5, gt=0, le=10, description="The payload (kg) with load='grasp'.")
    label: Literal["physics", "force_closure"] = Field("physics", description="What the train arms learn: the "
        "physics trials' outcome, or force closure at good_mu or better (the paper's label: closure scores on the "
        "source meshes for A and R, without lifting anything, and on the one object's patches at the settled pose "
        "of one trial for B). Held-out objects are always judged by physics, the stand-in for the paper's robot.")
    good_mu: float = Field(0.4, gt=0, le=10, description="With label='force_closure': a grasp is good when its "
                           "smallest friction level in force closure (graspnetAPI's sweep) is at most this.")
    points_per_grasp: int = Field(256, ge=16, le=4096, description="Gripper-frame points stored per grasp.")
    sampler: Literal["antipodal", "normal"] = Field("normal", description="Candidate sampler (the paper samples "
                                                    "along the surface normal).")
    views: int = Field(0, ge=0, le=256, description="0: every arm crops from the object's full surface; N: N depth "
                       "views per object, what a robot sees (docs/views.md), each crop from one view.")
    view_sampling: Literal["mesh", "view"] = Field("view", description="With views: candidates proposed on each "
        "view's cloud as the planner proposes them, each cropped from its view (view: what the camera gives), or "
        "sampled on the mesh and cropped from the nearest view (mesh).")
    judge: Literal["candidates", "picks", "both"] = Field("candidates", description="What decides: held-out top-1 "
        "and AP among candidates on the full mesh (candidates), pick success from one depth view (picks: every "
        "seed's network plans on the camera's cloud and its first choice is executed), or both side by side.")
    picks: StudyPicks = StudyPicks()
    ceiling_grasps: int = Field(256, ge=0, le=100_000, description="Held-out candidates (a seeded sample) "
                                "labelled again to measure the label's own ceiling: its self-agreement, its "
                                "positive-rate floor and the best AP against one draw (0: none; docs/study.md).")
    ceiling_draws: int = Field(3, ge=2, le=32, description="Fresh draws of each such candidate's label, each a new "
                               "execution of the protocol (its nominal trial perturbed too).")
    training: StudyTraining = StudyTraining()
    adaptive: StudyAdaptive | None = Field(None, description="Add the adaptive arm U (labels chosen by the "
                                           "network in rounds); none by default.")
    keys: tuple[StudyKey, ...] = Field((), description="Other dedup keys to measure as lookups from A's labels to "
                                       "the held-out labels (the key study, docs/key_study.md); none by default.")
    targets: StudyTargets = StudyTargets()

    @model_validator(mode="after")
    def _keys_crop_the_full_surface(self) -> StudySpec:
        if self.keys and self.views:
            raise ValueError("keys are computed from crops of the full surface: with views (partial crops) they "
                             "would not be the jobs' crops; set views: 0 or leave keys out")
        return self

    @field_validator("radii", "static_radii")
    @classmethod
    def _distinct_radii(cls, radii: tuple[int, ...]) -> tuple[int, ...]:
        if any(r < 0 or r > 64 for r in radii) or len(set(radii)) != len(radii):
            raise ValueError(f"{radii}: give distinct radii in [0, 64]")
        return radii

    @field_validator("budgets")
    @classmethod
    def _shares(cls, budgets: tuple[float, ...]) -> tuple[float, ...]:
        if any(not 0 < b <= 1 for b in budgets):
            raise ValueError(f"{budgets}: every budget is a share of A's labels in (0, 1]")
        return budgets

    def digest(self) -> str:
        """Names this study: a folder holding another digest's results holds another study."""
        return hashlib.blake2b(self.model_dump_json().encode(), digest_size=8).hexdigest()

    def closure(self, truth: bool = False) -> dict[str, Any]:
        """The jobs' closure settings: none for a physics study; with force closure, the scores and (for train
        jobs, not the held-out ``truth``) the label."""
        if self.label == "physics":
            return {}
        return {"enabled": True, "good_mu": self.good_mu, "label": "physics" if truth else "force_closure"}

    def job_spec(self, objects: str, grasps: int, seed: int, output: str, **update: Any) -> JobSpec:
        """The job every arm shares: the study's sampler, physics, label protocol and crop."""
        sim = {"label_trials": self.label_trials, "success": self.success, "perturbations_per_patch": 0,
               "load": self.load, "load_mass": self.load_mass, "transfer_codes": 0,
               "points_per_grasp": self.points_per_grasp, **update.pop("sim", {})}
        views = {"count": self.views, "crop": "partial", "sampling": self.view_sampling} if self.views else {}
        return JobSpec(objects=objects, grasps_per_object=grasps, seed=seed, output=output,
                       sampler={"method": self.sampler}, sim=sim, views=views, **update)


QUICK = {"grasps_per_object": 96, "heldout_grasps": 48, "radii": (0, 1), "budgets": (0.1, 0.25, 0.5),
         "label_trials": 2, "points_per_grasp": 128, "ceiling_grasps": 48,
         "training": {"model": "voxel", "steps": 200, "batch_size": 32, "learning_rates": (1e-3, 3e-3), "seeds": 3,
                      "evaluations": 5},
         "targets": {"bootstrap_draws": 1000, "ap_draws": 300}}  # --quick: minutes on two cores


def parse_study_spec(data: dict[str, Any], source: str = "<study>") -> StudySpec:
    """Validate a mapping into a :class:`StudySpec`; errors name the field, the value and the rule."""
    try:
        return StudySpec.model_validate(data)
    except ValidationError as err:
        raise SpecError(describe_validation_error(err, source, "study")) from None


def load_study_spec(path: str | Path | None, overrides: dict[str, Any], quick: bool = False) -> StudySpec:
    """The study of a YAML or JSON file (or the defaults), with ``--quick``'s sizes under the given fields and
    ``overrides`` (top-level fields) over both."""
    data: dict[str, Any] = dict(QUICK) if quick else {}
    if path is not None:
        data.update(_read_mapping(Path(path)))
    data.update({k: v for k, v in overrides.items() if v is not None})
    return parse_study_spec(data, str(path) if path else "command line")


def _read_mapping(path: Path) -> dict[str, Any]:
    import yaml

    try:
        text = path.read_text()
    except OSError as err:
        raise SpecError(f"{path}: cannot read study: {err.strerror}") from None
    try:
        data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise SpecError(f"{path}: not valid {'JSON' if path.suffix == '.json' else 'YAML'}: {err}") from None
    if not isinstance(data, dict | None):
        raise SpecError(f"{path}: a study must be a mapping of fields, got {type(data).__name__}")
    return data or {}
