"""Job status: a pydantic model written into the dataset folder, so it is readable after the cluster is gone."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from onepiece_dist.learn.metrics import EpochMetrics

JobState = Literal["pending", "running", "succeeded", "failed", "cancelled"]
STATUS_SUFFIX = ".status.json"
FINAL_STATUS_MARK = "ONEPIECE_FINAL_STATUS "  # a submitted driver's last log line: JobStatus.log_line


def status_path(output: str | os.PathLike) -> Path:
    """The status file of the dataset at ``output``: ``<output>.status.json`` beside it."""
    return Path(f"{Path(output)}{STATUS_SUFFIX}")


class Rejection(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    name: str
    reason: str


class Progress(BaseModel):
    model_config = ConfigDict(extra="forbid")
    objects_done: int = 0
    objects_total: int = 0
    objects_reused: int = 0
    grasps: int = 0
    unique_codes: int = 0


class _Report(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class AssemblyReport(_Report):
    """What the assemble stage built (also the dataset's ``assembly`` attribute)."""

    unique_codes: int = Field(description="Patches on the one object (one per unique code or cluster).")
    grasps_represented: int = Field(description="Extracted grasps whose codes the patches stand for.")
    plane_counts: dict[str, int] = Field(description="Patches per projection plane (uv, ut, vt).")
    bounding_box_m: list[float]
    patch_density_per_m2: float
    grid_pitch_m: list[float] = Field(description="Cell size of the patch grid on the core's faces (m).")
    patch_pieces: int = Field(description="Convex pieces of all patches (clipped from the source objects).")
    fidelity: float = Field(description="Share of placements whose crop reproduces the unique code.")
    fidelity_failures: list[int] = Field(description="First 100 patches whose crop does not.")
    chamfer_mm: float | None = Field(description="Mean symmetric Chamfer distance between a patch's crop on the "
                                     "one object and its representative's stored points (mm; None without points).")
    chamfer_max_mm: float | None = Field(description="The largest of those distances (mm).")
    chamfer_patches: int = Field(description="Patches compared (a fixed sample of at most 200).")
    corridor_intrusions: int = Field(description="Points of other patches inside a patch's approach corridor.")
    label_trials_one_object: int = Field(description="Label trials of the label stage on the one object: patches x "
                                         "(1 + perturbations) x label_trials.")
    label_trials_all_grasps: int = Field(description="Label trials that labelling every extracted grasp with the "
                                         "same protocol costs: grasps x label_trials.")


class PairAgreement(_Report):
    """Agreement of two labels over pairs of grasps: success (same outcome) and quality (Pearson correlation;
    None when either side is constant)."""

    pairs: int
    success_agreement: float | None
    quality_correlation: float | None


class TransferReport(_Report):
    """How far a label transfers between grasps that share a code (job/stages/label_transfer.py)."""

    codes: int = Field(description="Unique codes sampled (each with two or more source grasps).")
    grasps_labelled: int = Field(description="Source grasps labelled on their own objects for this measure.")
    label_trials: int
    patch_vs_source: PairAgreement = Field(description="(a) each patch on the one object vs its representative "
                                           "on the source object.")
    same_code: PairAgreement = Field(description="(b) the representative vs the other grasps of its code.")
    random_pairs: PairAgreement = Field(description="(c) random pairs with different codes: the floor.")


class LabelReport(_Report):
    """What the label stage on the one object did (also the dataset's ``assembly_labels`` attribute)."""

    label_trials: int
    labelled_grasps: int
    success_rate: float
    transfer: TransferReport | None = Field(None, description="Label transfer, when sim.transfer_codes > 0.")


class AdaptiveRound(_Report):
    """One round of adaptive labelling (job/stages/label_rounds.py)."""

    round: int
    labels: int = Field(description="Candidates labelled so far, the validation set included.")
    new: int = Field(description="Candidates this round labelled.")
    validation_ap: float = Field(description="AP on the validation objects of the checkpoint the round kept.")
    best_step: int
    train_seconds: float
    checkpoint: str = Field(description="The round's network (a plain state dict; its weights are also in the "
                            "dataset, adaptive/round_NNN/).")
    part: str = Field(description="The part holding the round's scores and weights (a resumed job reuses it).")


class AdaptiveReport(_Report):
    """What adaptive labelling did (also the dataset's ``adaptive`` attribute)."""

    candidates: int
    validation_objects: list[int] = Field(description="Rows in objects/ held out from the rounds.")
    validation_labels: int
    limit: int = Field(description="The most labels the rounds may spend (adaptive.limit).")
    stopped: str = Field(description="Why the rounds ended: patience, rounds, limit or all (every candidate).")
    rounds: list[AdaptiveRound]


class TrainingReport(_Report):
    """What the train stage fitted (also the dataset's ``training`` attribute)."""

    model: str
    data: str
    epochs: int
    stopped_early: bool
    checkpoint: str
    device: str
    final: EpochMetrics | None = Field(description="Metrics of the last epoch (None: no epoch ran).")

    @field_validator("final", mode="before")
    @classmethod
    def _no_epoch(cls, value):
        return None if value == {} else value  # written as {} before the metrics were typed


class EvaluationReport(_Report):
    """What the evaluate stage measured: the trained network on held-out objects (also the dataset's
    ``evaluation`` attribute)."""

    objects: int = Field(description="Held-out objects scored (rejected ones left out).")
    grasps: int = Field(description="Held-out candidates, every one labelled.")
    positive_rate: float
    top1: float = Field(description="Mean over objects of the success of the network's top-ranked candidate.")
    random_choice: float = Field(description="Mean over objects of a random candidate's expected success.")
    ap: float = Field(description="Average precision of the network's scores over every held-out candidate.")
    accuracy: float = Field(description="Share of candidates whose score is on the label's side of one half.")
    checkpoint: str
    dataset: str = Field(description="The labelled held-out dataset.")
    protocol: str = Field("", description="The label protocol the held-out candidates were judged by.")
    separable: bool | None = Field(None, description="False when the held-out positive rate is above 90% or below "
                                   "10%: then a network's top-1 cannot be told from a random choice's.")
    verdict: str = Field("", description="What the evaluation can and cannot say, in a sentence.")
    top1_interval: tuple[float, float] | None = Field(None, description="95% interval of top1 (objects resampled).")
    random_choice_interval: tuple[float, float] | None = Field(None, description="95% interval of random_choice.")
    above_guess_interval: tuple[float, float] | None = Field(None, description="95% interval of top1 minus "
                                                             "random_choice (objects resampled, paired).")


class JobStatus(BaseModel):
    """State of one job. ``timings`` holds seconds per stage."""

    model_config = ConfigDict(extra="forbid")
    job_id: str
    state: JobState = "pending"
    stage: str = ""
    output: str = ""
    progress: Progress = Field(default_factory=Progress)
    timings: dict[str, float] = Field(default_factory=dict)
    rejections: list[Rejection] = Field(default_factory=list)
    nodes: list[str] = Field(default_factory=list, description="Ray node ids that extracted objects.")
    retries: int = Field(0, description="Object tasks re-run after a worker died.")
    worker_seconds: float = Field(0.0, description="Time spent inside per-object extraction, summed over objects.")
    part_seconds: float = Field(0.0, description="What the objects' parts cost to make, summed over objects (a part "
                                "reused from an earlier run counts the time it took then): the extraction's "
                                "core-seconds.")
    label_seconds: float = Field(0.0, description="What the label stage's shards cost to make, summed over shards "
                                 "(a reused shard counts the time it took then): the label stage's core-seconds.")
    spec: dict = Field(default_factory=dict, description="The JobSpec (so a job can be resumed from its status).")
    assembly: AssemblyReport | None = Field(None, description="Report of the assemble stage.")
    labels: LabelReport | None = Field(None, description="Report of the label stage on the one object.")
    adaptive: AdaptiveReport | None = Field(None, description="Report of adaptive labelling's rounds.")
    training: TrainingReport | None = Field(None, description="Report of the train stage.")
    evaluation: EvaluationReport | None = Field(None, description="Report of the evaluate stage.")
    error: str = ""
    driver: str = Field("", description="'host:pid' of the process that drives the job (its pipeline).")
    created: float = Field(default_factory=time.time)
    updated: float = Field(default_factory=time.time)

    def save(self, output: str | os.PathLike) -> None:
        """Write atomically beside the dataset at ``output``."""
        self.updated = time.time()
        path = status_path(output)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_text(self.model_dump_json(indent=2))
        os.replace(tmp, path)

    @classmethod
    def load(cls, output: str | os.PathLike) -> JobStatus:
        return cls.model_validate(json.loads(status_path(output).read_text()))

    def log_line(self) -> str:
        """This status as the last line a submitted driver logs (``run --final-status``), for clients that read
        the log of a job that ended instead of asking the cluster's registry (api.Client.status)."""
        return FINAL_STATUS_MARK + self.model_dump_json()

    @classmethod
    def from_log(cls, log: str) -> JobStatus | None:
        """The last status a driver logged with :meth:`log_line`; None where it logged none."""
        lines = [line for line in log.splitlines() if line.startswith(FINAL_STATUS_MARK)]
        return cls.model_validate_json(lines[-1][len(FINAL_STATUS_MARK):]) if lines else None


def without_status_lines(log: str) -> str:
    """A driver's log as a user reads it: without its final-status line (a record for clients)."""
    if FINAL_STATUS_MARK not in log:
        return log
    return "".join(line for line in log.splitlines(keepends=True) if not line.startswith(FINAL_STATUS_MARK))
