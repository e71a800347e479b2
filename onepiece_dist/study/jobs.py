"""The jobs of a study, run through the service (embedded Ray, a cluster, or in process) and reused when their
dataset is already there, made from the very same spec: a study killed at any point goes on from what it finished.

Jobs: the held-out set (every candidate labelled), A (every train candidate labelled on its own object) and one B
job per radius (extraction once, in a parts cache the radii share; then dedup, the one object and its labels),
and one B static job per static radius (the same from crops at the candidate pose, no extraction physics).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from onepiece_dist.job.status import JobStatus
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.study.spec import StudySpec

Run = Callable[[JobSpec, str], JobStatus]  # (spec, job name) -> the finished job's status


@dataclass(frozen=True)
class StudyJobs:
    """Every job spec of a study, outputs under its folder's ``jobs/``."""

    heldout: JobSpec
    a: JobSpec
    b: dict[str, JobSpec]  # arm name ('B r0', 'B static r0') -> its B job; its radius is the job's similar_radius

    def named(self) -> list[tuple[str, JobSpec]]:
        return [("heldout", self.heldout), ("A", self.a), *self.b.items()]

    def settled_b(self) -> dict[str, JobSpec]:
        """The B arms whose extraction settles each grasp (not the static ones)."""
        return {name: job for name, job in self.b.items() if job.sim.physics}


def study_jobs(spec: StudySpec, folder: Path) -> StudyJobs:
    """The held-out job (every candidate labelled by physics trials: the truth), A and B per radius. With the
    force-closure label, A scores its candidates without lifting anything, and B labels each patch at the settled
    pose of one trial; the held-out job also keeps the closure scores (how well the label predicts the truth)."""
    jobs = folder / "jobs"
    stages = ("ingest", "extract", "dedup")
    closure = spec.label == "force_closure"
    heldout = spec.job_spec(spec.heldout, spec.heldout_grasps, spec.seed + 1, str(jobs / "heldout.zarr"),
                            sim={"label": True}, stages=stages, closure=spec.closure(truth=True))
    a = spec.job_spec(spec.train, spec.grasps_per_object, spec.seed, str(jobs / "A.zarr"),
                      sim={"label": not closure}, stages=stages, closure=spec.closure())
    b_sim = {"label_trials": 1} if closure else {}

    def b_job(radius: int, static: bool) -> JobSpec:
        tag = "-static" if static else ""
        return spec.job_spec(spec.train, spec.grasps_per_object, spec.seed, str(jobs / f"B{tag}-r{radius}.zarr"),
                             cache_dir=str(jobs / f"parts-B{tag}"), similar_radius=radius,
                             sim={**b_sim, **({"physics": False} if static else {})}, closure=spec.closure(),
                             stages=("ingest", "extract", "dedup", "assemble", "label"))

    b = {f"B r{r}": b_job(r, False) for r in spec.radii}
    b.update({f"B static r{r}": b_job(r, True) for r in spec.static_radii})
    return StudyJobs(heldout, a, b)


@dataclass(frozen=True)
class JobRecord:
    """A finished job of the study: its status and whether an earlier run of the study made it."""

    name: str
    spec: JobSpec
    status: JobStatus
    reused: bool


def run_or_reuse(name: str, spec: JobSpec, run: Run) -> JobRecord:
    """The job's finished status: read back when its dataset was made from this very spec, else run now (a job
    cut short before is run again on its committed parts)."""
    done = finished(spec)
    if done is not None:
        return JobRecord(name, spec, done, True)
    return JobRecord(name, spec, run(spec, name), False)


def finished(spec: JobSpec) -> JobStatus | None:
    """The status of a job that succeeded in making ``spec.output`` from this spec, or None."""
    path = Path(f"{spec.output}.status.json")
    if not path.is_file():
        return None
    status = JobStatus.model_validate_json(path.read_text())
    place = {"decompositions"}  # a local run keeps its decompositions in the user's folder: where, not what
    same = JobSpec.model_validate(status.spec).model_dump(exclude=place) == spec.model_dump(exclude=place)
    return status if same and status.state == "succeeded" else None


def core_seconds(status: JobStatus) -> dict[str, float]:
    """Core-seconds per stage of a finished job: extraction (and labels with sim.label) summed inside the workers,
    the label stage summed over its shards, the central actor's stages (one core) at their wall time."""
    stages = {"extract": status.worker_seconds, "dedup": status.timings.get("dedup", 0.0),
              "assemble": status.timings.get("assemble", 0.0), "label": status.label_seconds}
    return {k: round(v, 2) for k, v in stages.items() if v}
