"""The end-to-end section of docs/performance.md (benchmarks/results/bench_end_to_end.json): the job's rate, the
stages' shares, and where the rate stands against the physics it must run (bench_sim's protocol)."""

from __future__ import annotations

from benchmarks.pages.committed import met
from onepiece_dist.study.markdown import provenance, table

PINNED_SENTENCE = ("Speed work leaves codes and labels as they were: tests/test_pinned_job.py pins the codes, "
                   "representatives and labels of a small labelled job (3 objects x 24 candidates, every stage "
                   "to label), and fails when any of them changes.")


def end_to_end_section(r: dict, sim: dict | None = None) -> list[str]:
    stages, t = r["stage_seconds"], r["targets"]
    cores = r.get("core_seconds_by_stage")
    rows = [[s, stages[s], *([cores.get(s, "")] if cores else []), r["peak_memory_gib_by_stage"].get(s, "")]
            for s in stages]
    budget = r.get("budget_seconds", r.get("extract_dedup_assemble_seconds"))
    budget_target = t.get("budget_seconds", t.get("extract_dedup_assemble_seconds"))
    budget_stages = r.get("budget_stages", [s for s in stages if s != "ingest"])
    trained = (f" The train stage fits the {r['train']['model']} model for {r['train']['epochs']} epochs."
               if "train" in r and "train" in stages else "")
    lines = [f"## End to end: {provenance(r)}", "", f"{r['objects']} objects x {r['candidates_per_object']} "
             f"candidates, embedded Ray, physics on, fresh cache: {r['objects_ok']} objects accepted, "
             f"{r['grasps']:,} grasps, {r['unique_codes']:,} unique codes, {r['patches']:,} patches on the one "
             f"object.{trained}", "",
             *table(["stage", "wall seconds", *(["core-seconds (process tree CPU)"] if cores else []),
                     "peak memory of the process tree (GiB)"], rows), "",
             f"{' + '.join(budget_stages)}: {budget} s (target {budget_target} s: "
             f"{met(-budget, -budget_target)}); peak memory {r['peak_memory_gib']} GiB in all, "
             f"{r['peak_above_idle_gib']} GiB above Ray's idle {r['ray_idle_memory_gib']} GiB (target "
             f"{t['peak_memory_gib']} GiB: {met(-r['peak_memory_gib'], -t['peak_memory_gib'])}). Dataset "
             f"{r['dataset_bytes'] / 1e6:.0f} MB, parts {r['parts_bytes'] / 1e6:.0f} MB.", "",
             PINNED_SENTENCE]
    if "extract_candidates_per_s_per_core" in r:
        rate, target = r["extract_candidates_per_s_per_core"], t["extract_candidates_per_s_per_core"]
        lines += ["", f"Extract stage: {rate} candidates/s/core over {r['workers']} cores (target {target}: "
                      f"{met(rate, target)}); {r['extract_candidates_per_s_per_busy_core']} candidates/s per "
                      f"second spent inside extraction ({r['extract_worker_seconds']} worker-seconds, core-seconds "
                      "of the stage: "
                      f"{round(stages['extract'] * r['workers'], 1)})."
                      + (_in_run_ceiling(r["protocol"], rate, target) if "protocol" in r else _ceiling(sim, rate))]
    lab = r.get("label")
    if lab:
        ratio, target = lab["rate_over_protocol"], lab["target_rate_over_protocol"]
        verdict = _drift_verdict(lab["trials_per_s_per_core"], r.get("protocol"), "label", target)
        lines += ["", f"Label stage: {lab['trials_one_object']:,} label trials on the one object"
                  + (f" and {lab['trials_transfer']:,} for the label-transfer measure on source objects"
                     if lab["trials_transfer"] else "")
                  + f", {lab['trials_per_s_per_core']} trials per core-second of the stage: {ratio:.2f} x the label "
                  f"protocol's {lab['protocol_trials_per_s_per_core']} trials/s/core "
                  + (f"timed in this run ({_rounds(r['protocol'], 'label')})" if "protocol" in r else "from bench_sim")
                  + f" (target {target}: {verdict or met(ratio, target)})." + _patch_protocol(lab)]
    if "protocol" in r and lab:
        lines += ["", _physics_floor(r, lab, budget_target)]
    return lines


def _drift_verdict(rate: float, protocol: dict | None, name: str, target: float) -> str:
    """Met only against the fastest timing of the protocol in the run (the machine at its speed); "not
    established" when the median timing says met and the fastest does not (the machine slowed within the run)."""
    if not protocol or not protocol.get("rounds"):
        return ""
    fastest = max(round_[f"{name}_trials_per_s_per_core"] for round_ in protocol["rounds"])
    if rate / fastest >= target:
        return "met"
    if rate / protocol[f"{name}_trials_per_s_per_core"] >= target:
        return (f"not established: {rate / fastest:.2f} x the protocol's fastest timing ({fastest}); the machine's "
                "speed moved within the run")
    return "not met"


def _patch_protocol(lab: dict) -> str:
    """What the label protocol costs on the job's own patches, and the stage against that rate."""
    p = lab.get("patch_protocol")
    if not p:
        return ""
    return (f" The same protocol on the job's own patches ({p['patches']} patches spread over the one object, "
            f"{p['trials']} trials, one core, timed after the job): {p['label_trials_per_s_per_core']} trials/s/core, "
            f"{p['over_whole_objects']:.2f} x the whole-object protocol timed just before it "
            f"({p['whole_object_label_trials_per_s_per_core']})"
            + (f": a trial on a patch costs {1 / p['over_whole_objects'] - 1:.0%} more physics than one on a whole "
               "object" if p["over_whole_objects"] < 1 else "")
            + f". The stage runs at {lab['rate_over_patch_protocol']:.2f} x that patch rate, and at "
            f"{lab['rate_over_patch_protocol_two_at_once']:.2f} x the patch rate of two copies at once "
            f"({p['two_at_once_label_trials_per_s_per_core']} trials/s/core, both cores busy): the rest is what the "
            "pipeline around the trials and the service's other processes cost.")


def _physics_floor(r: dict, lab: dict, budget_target: float) -> str:
    """The extract and label stages' seconds on the job's cores if they ran at the protocol rates of this run."""
    p, cores = r["protocol"], r["workers"]

    def seconds(rates: dict) -> tuple[float, float]:
        return (r["objects"] * r["candidates_per_object"] / (cores * rates["extract_trials_per_s_per_core"]),
                (lab["trials_one_object"] + lab["trials_transfer"]) / (cores * rates["label_trials_per_s_per_core"]))

    extract, label = seconds(p)
    text = (f"The physics alone, at this run's protocol rates on {cores} cores, takes {extract:.0f} s to extract "
            f"and {label:.0f} s to label: {extract + label:.0f} s before dedup and assembly, against the target of "
            f"{budget_target} s for all four stages ({'within' if extract + label < budget_target else 'above'} "
            "it).")
    if "two_at_once" in p:  # the rates the job's cores give when both are busy, as they are in the job
        extract, label = seconds(p["two_at_once"])
        text += (f" At the rates of two copies at once (both cores busy, as the job runs them): {extract:.0f} s and "
                 f"{label:.0f} s, {extract + label:.0f} s "
                 f"({'within' if extract + label < budget_target else 'above'} the target).")
    return text


def _rounds(protocol: dict, name: str) -> str:
    before, after = (f"{row[f'{name}_trials_per_s_per_core']}" for row in protocol["rounds"])
    return f"{before} before the job, {after} after it"


def _in_run_ceiling(protocol: dict, rate: float, target: float) -> str:
    extract = protocol["extract_trials_per_s_per_core"]
    return (f" The extract protocol alone (one settling trial per candidate, no sampling, crops or writing), timed in "
            f"this run on {protocol['objects_loaded']} of the job's objects ({protocol['trials']:,} candidates, one "
            f"core, nothing else running), runs at {extract} trials/s/core ({_rounds(protocol, 'extract')}): this "
            f"stage runs at {rate / extract:.0%} of it."
            + (f" The target {target} is above the protocol itself, the physics alone: no overhead cut can reach it "
               "on this machine; cheaper physics would, and changes the codes (bench_sim's extract fidelity below)."
               if extract < target else "") + _two_at_once(protocol, rate))


def _two_at_once(protocol: dict, rate: float) -> str:
    """The protocols with both cores busy (two copies at once), as the job's two workers run."""
    both = protocol.get("two_at_once")
    if not both:
        return ""
    return (f" Two copies of the protocols at once, one per core (as the job's two workers run), after the job: "
            f"extract {both['extract_trials_per_s_per_core']} and label {both['label_trials_per_s_per_core']} "
            f"trials/s/core, {both['over_alone']['extract_trials_per_s_per_core']:.2f} and "
            f"{both['over_alone']['label_trials_per_s_per_core']:.2f} x one copy with the other core idle: what "
            f"this machine gives two busy cores. This stage runs at {rate / both['extract_trials_per_s_per_core']:.0%} "
            "of the two-at-once extract rate.")


def _ceiling(sim: dict | None, rate: float) -> str:
    if not sim or "physical_defaults" not in sim:
        return ""
    protocol = sim["extract_trials_per_s_per_core"]
    return (f" The extract protocol alone (one settling trial per candidate, no sampling, crops or writing) runs at "
            f"{protocol} trials/s/core on {sim['objects']} (bench_sim, {sim['date']}): this stage runs at "
            f"{rate / protocol:.0%} of it, on other objects.")
