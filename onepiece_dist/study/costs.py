"""What each arm of a study costs: core-seconds by stage, label trials, labelled and delivered bytes."""

from __future__ import annotations

from pathlib import Path

from onepiece_dist.study.jobs import JobRecord, StudyJobs, core_seconds
from onepiece_dist.study.result import ArmCost
from onepiece_dist.study.spec import StudySpec


def arm_costs(spec: StudySpec, jobs: StudyJobs, records: dict[str, JobRecord], shares: list[tuple[str, int]],
              adaptive_labels: int | None = None) -> dict[str, ArmCost]:
    """Each arm's cost. B's extraction (shared by the radii through the parts cache) is charged in full to each
    radius; R labels its candidates on their own objects, at A's cost per candidate. U extracts every candidate
    (it picks by code and by the network's score of each crop: B's extraction) and labels its picks at A's label
    cost per candidate (A's cost beyond that extraction); its rounds' training is compute, not labels, and is not
    counted."""
    from onepiece_dist.store.dataset import delivered_bytes, disk_bytes

    k = spec.label_trials if spec.label == "physics" else 0  # force closure labels A without lifting anything
    a = records["A"].status
    a_stages = core_seconds(a)
    a_cost = ArmCost(core_seconds=round(sum(a_stages.values()), 2), stages=a_stages,
                     label_trials=a.progress.grasps * k, labelled_grasps=a.progress.grasps,
                     labelled_bytes=disk_bytes(Path(jobs.a.output) / "grasps"),
                     dataset_bytes=disk_bytes(Path(jobs.a.output)), delivered_bytes=delivered_bytes(jobs.a.output))
    costs = {"A": a_cost}
    extract = {}  # the arms of one parts cache share one extraction: each is charged all of it
    for name, job in jobs.b.items():
        seconds = core_seconds(records[name].status).get("extract", 0.0)
        extract[job.cache_dir] = max(extract.get(job.cache_dir, 0.0), seconds)
    b_extract = max((extract[job.cache_dir] for job in jobs.settled_b().values()), default=0.0)
    for name, job in jobs.b.items():
        status = records[name].status
        stages = {**core_seconds(status), "extract": extract[job.cache_dir]}
        labelled = Path(job.output) / "assembled" / "grasps"
        costs[name] = ArmCost(
            core_seconds=round(sum(stages.values()), 2), stages=stages,
            label_trials=status.labels.label_trials if status.labels else 0,
            labelled_grasps=status.labels.labelled_grasps if status.labels else 0,
            labelled_bytes=disk_bytes(labelled) if labelled.exists() else 0, dataset_bytes=disk_bytes(Path(job.output)),
            delivered_bytes=delivered_bytes(job.output))
    shares = list(shares)  # each R arm's (name, labelled grasps)
    if adaptive_labels is not None:
        shares += [("U", adaptive_labels), ("R ~U", adaptive_labels)]
    for name, count in shares:
        share = count / max(a.progress.grasps, 1)
        stages = {stage: round(share * seconds, 2) for stage, seconds in a_stages.items()}
        if name == "U":  # U needs every candidate's code and crop: B's extraction, then A's label cost per label
            per_label = max(a_cost.core_seconds - b_extract, 0.0) / max(a.progress.grasps, 1)
            stages = {"extract": round(b_extract, 2), "label": round(count * per_label, 2)}
        costs[name] = ArmCost(core_seconds=round(sum(stages.values()), 2), stages=stages, label_trials=count * k,
                              labelled_grasps=count, labelled_bytes=int(share * a_cost.labelled_bytes),
                              dataset_bytes=int(share * a_cost.dataset_bytes),
                              delivered_bytes=int(share * a_cost.delivered_bytes))
    return costs
