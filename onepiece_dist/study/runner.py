"""Running a study: its input checked before any work, its jobs on the service (embedded Ray, a cluster, or in
process), every arm trained through trainer actors, scored on the held-out objects, decided, and written to its
folder as ``study.json`` (a :class:`StudyResult`), ``study.md`` and its plot.

A study's folder holds one study: ``study.spec.json`` names it, and a folder holding another's is refused. Every
job and training run is kept there, so a study killed at any point finishes when run again, reusing what it had
finished, with the same result.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import platform
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import date
from pathlib import Path

import numpy as np

from onepiece_dist.api import run_job
from onepiece_dist.errors import MeshRejected, SourceError, SpecError
from onepiece_dist.job.stages.label_budget import budget_rows
from onepiece_dist.job.status import JobStatus
from onepiece_dist.learn.train import StepResult, StepRun
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.runtime.ray_env import connect
from onepiece_dist.runtime.trainer import Trainer, run_step_runs, trainers_on_ray
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.stats.ceiling import MEASURED_DRAWS, ap_against_draws, label_ceiling, measured_ceiling
from onepiece_dist.store import open_dataset
from onepiece_dist.study.adaptive import adaptive_rows
from onepiece_dist.study.costs import arm_costs
from onepiece_dist.study.decide import ArmDraft, decide, finish_arms
from onepiece_dist.study.jobs import JobRecord, StudyJobs, run_or_reuse, study_jobs
from onepiece_dist.study.keys import key_measures
from onepiece_dist.study.label_draws import heldout_label_draws
from onepiece_dist.study.lookup import key_lookup
from onepiece_dist.study.page import write_pages
from onepiece_dist.study.picks import judge_by_picks, judges_picks, weights_base
from onepiece_dist.study.premise import label_fit, premise
from onepiece_dist.study.result import (
    ArmRound,
    Baselines,
    Ceiling,
    HeldoutScore,
    Measure,
    SeedRun,
    StudyResult,
)
from onepiece_dist.study.spec import StudySpec
from onepiece_dist.study.stats import arm_summary, baselines
from onepiece_dist.study.training import ArmRun, RunStore, train_arms
from onepiece_dist.version import package_version

Say = Callable[[str], None]  # progress lines (the CLI prints them on stderr)
SPEC_FILE, RESULT_FILE = "study.spec.json", "study.json"


@dataclass(frozen=True)
class Where:
    """Where a study's work runs: an embedded Ray on the loopback (default), the cluster at ``address``, or this
    process without Ray (``in_process``: debugging and tests)."""

    address: str | None = None
    in_process: bool = False
    workers: int | None = None


ARM_FIELDS = ("radii", "static_radii", "budgets", "adaptive", "keys", "targets")  # what an extension may change


def same_base(one: StudySpec, other: StudySpec) -> bool:
    """Whether two studies differ at most in their arms and targets: the same objects, label protocol, crops and
    training, so every job and run they share is the same."""
    return one.model_dump(exclude=set(ARM_FIELDS)) == other.model_dump(exclude=set(ARM_FIELDS))


def check_folder(spec: StudySpec, folder: Path, extend: bool = False) -> Path:
    """``folder`` as an absolute path; refused when it holds another study's results or other files. With
    ``extend``, a study that differs from the folder's only in its arms or targets (ARM_FIELDS) takes the folder
    over: it reuses every job and run they share and its result replaces the folder's."""
    folder = folder.resolve()
    marker = folder / SPEC_FILE
    if marker.is_file():
        other = StudySpec.model_validate_json(marker.read_text())
        if other != spec and not (extend and same_base(other, spec)):
            hint = (" or add --extend: it differs only in its arms or targets, so it reuses that study's jobs and "
                    "runs and replaces its result" if same_base(other, spec) else "")
            raise SpecError(f"{folder} holds another study's results (study {other.digest()}, not {spec.digest()}); "
                            f"give another --out, or remove that folder{hint}")
    elif folder.is_dir() and any(folder.iterdir()):
        raise SpecError(f"{folder} is not empty and holds no study: give an empty or new --out")
    return folder


def claim_folder(spec: StudySpec, folder: Path) -> None:
    """Mark ``folder`` as this study's (``study.spec.json``; an extended study's replaces the one before)."""
    folder.mkdir(parents=True, exist_ok=True)
    marker = folder / SPEC_FILE
    if not marker.is_file() or StudySpec.model_validate_json(marker.read_text()) != spec:
        tmp = folder / f".{SPEC_FILE}.tmp"
        tmp.write_text(spec.model_dump_json(indent=2))
        os.replace(tmp, marker)


def check_objects(spec: StudySpec) -> None:
    """Before any work: both sources resolve, each has an object that loads, and no held-out object is a train
    object (same mesh content). Raises :class:`SourceError` naming the objects."""
    job = spec.job_spec(spec.train, spec.grasps_per_object, spec.seed, "unused.zarr")
    ids: dict[str, dict[str, str]] = {}
    for role, source in (("train", spec.train), ("heldout", spec.heldout)):
        refs, ids[role], rejected = resolve_source(source), {}, []
        for ref in refs:
            try:
                ids[role][load_object(ref, job).mesh.content_id] = ref.name
            except MeshRejected as err:
                rejected.append(f"{ref.name}: {err.reason}")
        if not ids[role]:
            raise SourceError(f"--{role} {source!r}: all {len(refs)} objects were rejected:\n  "
                              + "\n  ".join(rejected))
    shared = sorted(set(ids["train"]) & set(ids["heldout"]), key=lambda c: ids["heldout"][c])
    if shared:
        names = ", ".join(f"{ids['heldout'][c]} (= train {ids['train'][c]})" for c in shared)
        raise SourceError(f"{len(shared)} held-out objects are also train objects (same mesh): {names}; a held-out "
                          "object must be unseen")


@contextlib.contextmanager
def job_runner(where: Where, prefix: str, say: Say) -> Iterator[Callable[[JobSpec, str], JobStatus]]:
    """A function that runs a job to completion where the study runs (Ray connected once for the whole study)."""
    started_here = False
    if not where.in_process:
        import ray


        started_here = not ray.is_initialized()
        connect(where.address)

    def run(spec: JobSpec, name: str) -> JobStatus:
        job_id = f"{prefix}-{name.replace(' ', '')}-{os.urandom(3).hex()}"  # a cut-short run's id stays taken
        shown: list[str] = []

        def progress(status: JobStatus) -> None:
            if status.stage and status.stage not in shown:
                shown.append(status.stage)
                say(f"study: {name}: {status.stage}")

        return run_job(spec, address=where.address, in_process=where.in_process, job_id=job_id,
                       workers=where.workers, progress=progress)

    try:
        yield run
    finally:
        if started_here:
            import ray

            with contextlib.suppress(Exception):
                ray.shutdown()


def trainer_runner(where: Where, prefix: str, device: str, limit: int):
    """A function that trains step runs in parallel on trainer actors (or in this process)."""
    def train(runs: list[StepRun], done) -> list[StepResult]:
        if where.in_process:
            return run_step_runs(runs, [Trainer().fit_steps], done)
        clients = trainers_on_ray(f"{prefix}-trainer-{os.urandom(3).hex()}", device, min(limit, len(runs)))
        try:
            return run_step_runs(runs, [client.fit_steps for client in clients], done)
        finally:
            for client in clients:
                with contextlib.suppress(Exception):
                    client.kill()

    return train


def run_study(spec: StudySpec, folder: str | Path, where: Where = Where(), say: Say = lambda line: None,
              extend: bool = False) -> StudyResult:
    """Run (or finish) the study in ``folder`` and write its result and pages there; ``extend``: see
    :func:`check_folder`."""
    start = time.perf_counter()
    folder = check_folder(spec, Path(folder), extend)
    check_objects(spec)  # before anything is written
    claim_folder(spec, folder)
    jobs = study_jobs(spec, folder)
    prefix = f"study-{spec.digest()[:8]}"
    with job_runner(where, prefix, say) as run:
        records = {name: run_or_reuse(name, job, run) for name, job in jobs.named()}
        for name, record in records.items():
            say(f"study: {name}: {'reused' if record.reused else 'done'} ({record.status.progress.grasps} grasps)")
        check_jobs(records)
        arm_runs = plan_runs(spec, jobs, records)
        store = RunStore(folder / "runs")
        say(f"study: training {len(arm_runs)} runs (+ learning-rate probes)")
        trained, search = train_arms(arm_runs, spec.training.learning_rates, store,
                                     trainer_runner(where, prefix, spec.training.device, len(arm_runs)))
        rounds = None
        if spec.adaptive is not None:
            rounds, more = train_adaptive(spec, jobs, search, store, where, prefix, say)
            trained += more
    drawn = label_draws_of(spec, jobs, folder, say)
    result = assemble_result(spec, jobs, records, trained, start, store.reused, rounds)
    picks = judge_by_picks(spec, folder, trained, result.arms, say) if judges_picks(spec) else None
    result = result.model_copy(update={"ceiling": drawn and ceiling_of(*drawn, trained), "picks": picks})
    write_result(result, folder)
    say(f"study: done in {result.wall_seconds:.0f} s: {folder / RESULT_FILE}")
    return result


def label_draws_of(spec: StudySpec, jobs: StudyJobs, folder: Path, say: Say) -> tuple[np.ndarray, np.ndarray] | None:
    """The held-out label drawn again on a seeded sample (job.label_draws): (rows, (rows, draws) bool), kept in
    ``ceiling.json`` so a study run again reuses them; None when the spec asks for none."""
    if not spec.ceiling_grasps:
        return None
    path = folder / "ceiling.json"
    asked = {"grasps": spec.ceiling_grasps, "draws": spec.ceiling_draws, "seed": spec.seed}
    if path.is_file():
        kept = json.loads(path.read_text())
        if kept["asked"] == asked and "draws" in kept:
            return np.asarray(kept["rows"], dtype=np.int64), np.asarray(kept["draws"], dtype=bool)

    say(f"study: the label's ceiling: {spec.ceiling_grasps} held-out candidates x {spec.ceiling_draws} draws")
    rows, draws = heldout_label_draws(jobs.heldout, jobs.heldout.output, spec.ceiling_grasps, spec.ceiling_draws,
                                      spec.seed)
    path.write_text(json.dumps({"asked": asked, "rows": rows.tolist(), "draws": draws.astype(int).tolist()}) + "\n")
    return rows, draws


def ceiling_of(rows: np.ndarray, draws: np.ndarray, trained: list[tuple[ArmRun, StepResult]]) -> Ceiling:
    """The label's ceiling from the draws, and each arm's networks against the same executions: their averaged
    scores (an ensemble) and each network alone."""
    scores: dict[str, list[np.ndarray]] = {}
    for job, result in trained:
        scores.setdefault(job.arm, []).append(result.scores[rows])
    arm_ap = {arm: round(ap_against_draws(np.mean(found, axis=0), draws), 4) for arm, found in scores.items()}
    single_ap = {arm: round(float(np.mean([ap_against_draws(one, draws) for one in found])), 4)
                 for arm, found in scores.items()}
    measured = {}
    if draws.shape[1] >= MEASURED_DRAWS:
        m = measured_ceiling(draws)
        measured = {"measured_ap": round(m.ap, 4), "measured_interval": (round(m.low, 4), round(m.high, 4)),
                    "moment_range": tuple(round(x, 4) for x in m.moment_range)}
    return Ceiling(**dataclasses.asdict(label_ceiling(draws)), arm_ap=arm_ap, single_ap=single_ap, **measured)


def check_jobs(records: dict[str, JobRecord]) -> None:
    for name in ("A", "heldout"):
        status = records[name].status
        if status.progress.grasps == 0:
            reasons = "; ".join(f"{r.name}: {r.reason}" for r in status.rejections) or "no grasp found"
            raise SourceError(f"the study's {name} job extracted no grasp: {reasons}")


def train_adaptive(spec: StudySpec, jobs: StudyJobs, search: dict, store: RunStore, where: Where, prefix: str,
                   say: Say) -> tuple[list[ArmRound], list[tuple[ArmRun, StepResult]]]:
    """The adaptive arm U (study.adaptive) at A's learning rate, and R ~U, random rows of U's size."""
    rate = search["A"]["chosen"] if search else spec.training.learning_rates[0]
    one = trainer_runner(where, prefix, spec.training.device, 1)
    rows, rounds = adaptive_rows(spec, jobs.a.output, rate, lambda run: store.train([run], one)[0])
    say(f"study: U: {len(rounds)} rounds, {len(rows)} labels")
    plan = (arm_runs(spec, jobs, "U", jobs.a.output, "grasps", rows)
            + arm_runs(spec, jobs, "R ~U", jobs.a.output, "grasps", random_rows(jobs.a.output, len(rows), spec.seed)))
    trained, _ = train_arms(plan, (rate,), store, trainer_runner(where, prefix, spec.training.device, len(plan)))
    return rounds, trained


def arm_runs(spec: StudySpec, jobs: StudyJobs, arm: str, path: str, group: str,
             rows: tuple[int, ...] | None) -> list[ArmRun]:
    """One arm's runs, a seed each, scored on the held-out objects."""
    t = spec.training
    weighting = t.b_weighting if group == "assembled/grasps" else "none"
    base = StepRun(path, group, rows, jobs.heldout.output, t.model, t.steps, t.batch_size, t.learning_rates[0],
                   t.validation, 0, t.evaluations, weighting=weighting, device=t.device)
    folder = Path(jobs.a.output).parent.parent  # picks need each run's weights: kept in the study's folder
    return [ArmRun(arm, seed, t.learning_rates[0], dataclasses.replace(
        base, seed=seed, save_to=weights_base(folder, arm, seed) if judges_picks(spec) else None))
        for seed in range(t.seeds)]


def plan_runs(spec: StudySpec, jobs: StudyJobs, records: dict[str, JobRecord]) -> list[ArmRun]:
    """Every arm's runs: A on all its labelled grasps, B r on its one object, R on a budget's subsets of A's."""
    a_count = records["A"].status.progress.grasps
    plan = arm_runs(spec, jobs, "A", jobs.a.output, "grasps", None)
    for name, job in jobs.b.items():
        plan += arm_runs(spec, jobs, name, job.output, "assembled/grasps", None)
    for name, count in random_arms(spec, records, a_count):
        plan += arm_runs(spec, jobs, name, jobs.a.output, "grasps", random_rows(jobs.a.output, count, spec.seed))
    return plan


def random_arms(spec: StudySpec, records: dict[str, JobRecord], a_count: int) -> list[tuple[str, int]]:
    """(name, labelled grasps) of each R arm: one per budget share, one the size of each B arm."""
    arms = [(f"R {share:g}", max(2, min(a_count, round(share * a_count)))) for share in spec.budgets]
    for name in (name for name in records if name.startswith("B ")):
        labels = records[name].status.labels
        arms.append((f"R ~{name}", max(2, min(a_count, labels.labelled_grasps if labels else 0))))
    return arms


def random_rows(a_output: str, count: int, seed: int) -> tuple[int, ...]:
    """The rows of A a budget job with ``count`` labels would label (``job.stages.label_budget.budget_rows``: spread
    over every object, at random within each, seeded): R is that plan, its labels A's (the same for every training
    seed)."""
    owner = open_dataset(a_output)["grasps/object"].astype(np.int64)
    return tuple(int(r) for r in budget_rows(owner, count, seed))


def assemble_result(spec: StudySpec, jobs: StudyJobs, records: dict[str, JobRecord],
                    trained: list[tuple[ArmRun, StepResult]], start: float, reused_runs: int,
                    rounds: list[ArmRound] | None = None) -> StudyResult:
    ho = open_dataset(jobs.heldout.output)
    labels, groups = ho["grasps/success"].astype(np.float64), ho["grasps/object"].astype(np.int64)
    drafts = arm_drafts(spec, jobs, records, trained, labels, groups, rounds[-1].labels if rounds else None)
    arms = finish_arms(drafts)
    a = open_dataset(jobs.a.output)
    premises = [premise(a, open_dataset(job.output), job.similar_radius, spec.seed)
                for name, job in jobs.settled_b().items() if records[name].status.labels is not None]
    rejected = sorted({f"{r.name}: {r.reason}" for rec in records.values() for r in rec.status.rejections})
    status = records["A"].status
    return StudyResult(spec=spec, digest=spec.digest(), date=date.today().isoformat(),
                       machine=f"{platform.machine()}, {os.cpu_count()} cores", package_version=package_version(),
                       wall_seconds=round(time.perf_counter() - start, 1),
                       reused_jobs=[name for name, rec in records.items() if rec.reused], reused_runs=reused_runs,
                       train_objects=status.progress.objects_done - len(status.rejections), rejected=rejected,
                       heldout=Baselines(**baselines(labels, groups)), arms=arms, premise=premises,
                       adaptive=rounds,
                       lookup=key_lookup(a["grasps/code"], a["grasps/success"], ho["grasps/code"], labels > 0,
                                         spec.seed),
                       keys=key_measures(spec.keys, jobs.a, jobs.heldout, spec.seed),
                       label_fit=label_fit(ho, spec.good_mu) if spec.label == "force_closure" else None,
                       decision=decide(arms, spec.targets))


def arm_drafts(spec: StudySpec, jobs: StudyJobs, records: dict[str, JobRecord],
               trained: list[tuple[ArmRun, StepResult]], labels: np.ndarray, groups: np.ndarray,
               adaptive_labels: int | None = None) -> list[ArmDraft]:
    costs = arm_costs(spec, jobs, records, random_arms(spec, records, records["A"].status.progress.grasps),
                      adaptive_labels)
    drafts = []
    for name, cost in costs.items():
        runs = [(job, result) for job, result in trained if job.arm == name]
        kind = name[0]
        radius = int(name.rsplit("r", 1)[1]) if name.startswith(("B", "R ~B")) else None
        share = float(name[2:]) if kind == "R" and not name.startswith("R ~") else None
        b = records.get(name) if kind == "B" else None
        drafts.append(ArmDraft(name, kind, cost, heldout_score(spec, runs, labels, groups), radius, share,
                               b.status.progress.unique_codes if b else None))
    return drafts


def heldout_score(spec: StudySpec, runs: list[tuple[ArmRun, StepResult]], labels: np.ndarray,
                  groups: np.ndarray) -> HeldoutScore:
    t = spec.targets
    summary = arm_summary([{"scores": r.scores, "seed": job.seed, "best_step": r.best_step,
                            "train_seconds": r.train_seconds, "train_grasps": r.train_grasps} for job, r in runs],
                          labels, groups, draws=t.bootstrap_draws, ap_draws=t.ap_draws, confidence=t.confidence)

    def m(key: str) -> Measure:
        interval = summary[key].get("ci95", [summary[key]["mean"]] * 2)
        return Measure(mean=round(summary[key]["mean"], 4), std=round(summary[key]["std"], 4),
                       interval=(interval[0], interval[1]))

    return HeldoutScore(top1=m("top1"), top5=m("top5"), ap=m("ap"), accuracy=m("accuracy"),
                        learning_rate=runs[0][0].learning_rate, seeds=[SeedRun(**s) for s in summary["seeds"]])


def write_result(result: StudyResult, folder: Path) -> None:
    tmp = folder / f".{RESULT_FILE}.tmp"
    tmp.write_text(result.model_dump_json(indent=2) + "\n")
    os.replace(tmp, folder / RESULT_FILE)
    write_pages(result, folder)


def report_study(folder: str | Path) -> StudyResult:
    """Render a study's pages again from its ``study.json``."""
    path = Path(folder) / RESULT_FILE
    if not path.is_file():
        raise SpecError(f"{path}: no study result here (run `onepiece study run ... --out {folder}` first)")
    result = StudyResult.model_validate_json(path.read_text())

    decision = decide(list(result.arms), result.spec.targets)  # figures a result from older code lacks
    if decision != result.decision:
        result = result.model_copy(update={"decision": decision})
        write_result(result, Path(folder))
    else:
        write_pages(result, Path(folder))
    return result
