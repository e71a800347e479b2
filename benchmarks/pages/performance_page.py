"""docs/performance.md from benchmarks/results/*.json (benchmarks/pages/report.py writes it with every other
page; `scripts/dev bench` runs that after the benchmarks).

Every table comes from a result file, with the command that made it and the date and machine it ran on; a
benchmark whose result file is missing is listed as not run.
"""

from __future__ import annotations

from benchmarks.pages.committed import HERE, RESULTS, load, met
from benchmarks.pages.end_to_end_section import end_to_end_section
from benchmarks.pages.suite_section import suite_section
from onepiece_dist.study.markdown import pct, provenance, table

PAGE = HERE.parent / "docs" / "performance.md"


def dedup_section(r: dict) -> list[str]:
    return [f"## Exact dedup: {provenance(r)}", "", *table(
        ["codes", "bits", "unique", "seconds (1 core)", "codes/s", "extra peak RSS", "pairwise baseline (est.)",
         "speedup"],
        [[f"{r['codes']:,}", r["code_bits"], f"{r['unique']:,}", r["seconds"], f"{r['codes_per_second'] / 1e6:.1f} M",
          f"{r['extra_peak_rss_mb']} MB", f"{r['pairwise_baseline_seconds_estimated']:,.0f} s",
          f"{r['speedup_vs_pairwise']:,}x"]]),
        "", f"Targets: under 3 s ({r['seconds']} s: {met(-r['seconds'], -3)}) and under 1 GB of extra memory "
        f"({r['extra_peak_rss_mb']} MB: {met(-r['extra_peak_rss_mb'], -1000)}). The baseline compares every pair of "
        "a 20,000-code sample and is extrapolated to N(N-1)/2 pairs in the same run."]


def merge_section(r: dict) -> list[str]:
    by_size = {row["codes"]: row for row in r["central_actor"]}
    parted = {row["codes"]: row for row in r["partitioned"]}
    rows = [[f"{c['codes'] / 1e6:g} M", f"{c['unique']:,}", f"{c['codes_per_s'] / 1e6:.2f} M",
             f"{by_size[c['codes']]['codes_per_s'] / 1e6:.2f} M", f"{c['state_bytes'] / 2**20:.0f} MiB",
             f"{parted[c['codes']]['codes_per_s'] / 1e6:.2f} M ({parted[c['codes']]['partitions']} actors)",
             f"{parted[c['codes']]['largest_shard_state_bytes'] / 2**20:.0f} MiB"] for c in r["central"]]
    base, part = r["baseline_resort_each_batch"], r["part_read"]
    slowest = min(row["codes_per_s"] for row in r["central_actor"])
    largest = max(row["state_bytes"] for row in r["central"])
    return [f"## Global merge: {provenance(r)}", "", *table(
        ["codes", "unique", "merge, in process", "through the CentralActor Ray actor", "dedup state",
         "partitioned by hash prefix", "largest partition state"], rows), "",
        f"Batches of {r['batch']} codes (one object's grasps), 64-bit codes. Baseline in the same run (re-sort the "
        f"whole table per batch, the previous index): {base['codes_per_s'] / 1e6:.2f} M codes/s on "
        f"{base['codes'] / 1e6:g} M codes (ours: {r['speedup_vs_baseline_at_first_size']}x faster). Reading each part "
        f"back from the store (the path after an actor restart) costs {part['ms_per_part']} ms per part "
        f"({part['codes_per_s'] / 1e6:.2f} M codes/s). Targets: at least 1 M codes/s through the central path "
        f"(slowest: {slowest / 1e6:.2f} M: {met(slowest, 1e6)}) and at most 2 GB of dedup state at 20 M codes "
        f"({largest / 2**20:.0f} MiB: {met(-largest, -2e9)}). On 2 cores the partitioned actors share the cores "
        "with the router, so they are slower than one actor here; they exist for memory and for clusters "
        "(docs/scaling.md)."]


def sim_section(r: dict) -> list[str]:
    t = r["targets"]
    timed = (f" Rates: the median of {r['repeats']} timings over all objects (range: "
             + ", ".join(f"{k} {low}-{high}" for k, (low, high) in r["rate_range_over_repeats"].items()) + ")."
             if "repeats" in r else "")
    return [f"## Grasp trials: {provenance(r)}", "", f"{r['objects']}, {r['trials']} antipodal candidates, "
            f"default gripper, one core.{timed}", "", *table(
                ["protocol", "trials/s/core", "vs fixed-step baseline", "target"],
                [["extract (close until stall, settle)", r["extract_trials_per_s_per_core"],
                  f"{r['extract_speedup_vs_baseline']}x", _target(r, t, "extract_trials_per_s_per_core")],
                 ["label (extract + lift + shakes, early drop exit)", r["label_trials_per_s_per_core"],
                  f"{r['label_speedup_vs_baseline']}x", _target(r, t, "label_trials_per_s_per_core")],
                 ["baseline: fixed 120-step close and lift", r["baseline_trials_per_s_per_core"], "1x", ""]]),
            *_physics_lines(r), *_fidelity_lines(r), *_extract_fidelity_lines(r)]


def _extract_fidelity_lines(r: dict) -> list[str]:
    fid = r.get("extract_fidelity")
    if not fid:
        return []
    floor = fid["noise_floor"]
    return ["", "Extract fidelity: the extract protocol's result is the settled pose, keyed by its code. The same "
            "candidates under other settings, against the default: same held/dropped outcome, and among candidates "
            f"held under both, the same code. Noise floor: moving every candidate by {floor['jitter_m'] * 1e6:.0f} "
            f"um keeps {floor['code_agreement']:.1%} of the codes. Rates here are timed once (see the range above "
            "for how much one timing varies).", "", *table(
                ["settings", "extract trials/s/core (once)", "held fraction", "same outcome", "same code"],
                [[row["settings"], row["extract_trials_per_s_per_core"], f"{row['held_fraction']:.3f}",
                  f"{row['held_agreement']:.1%}", pct(row["code_agreement"])] for row in fid["rows"]])]


def _physics_lines(r: dict) -> list[str]:
    phys = r.get("physical_defaults")
    if not phys:
        return []
    return ["", f"Physical defaults of this run (docs/trials.md): pad friction {phys['pad_friction']}, closing force "
            f"{phys['closing_force_n']} N per finger, density {phys['density_kg_m3']} kg/m^3; an extract trial "
            f"closes in {r['extract_closing_steps_per_trial']} steps on average and "
            f"{r['extract_held_fraction']:.1%} of the candidates hold. These rates are the ceiling of the stages "
            "built on them: on the same objects the extract stage cannot run more candidates per second per core "
            "than the extract protocol does."]


def _target(r: dict, targets: dict, name: str) -> str:
    return f"{targets[name]} ({met(r[name], targets[name])})"


def _fidelity_lines(r: dict) -> list[str]:
    fid = r.get("label_fidelity")
    if not fid:
        return []
    ref, floor = fid["reference"], fid["noise_floor"]

    def settings(row: dict) -> str:
        return (f"1/{round(1 / row['time_step'])} s, {row['solver_iterations']} iterations, "
                f"{'cone' if row['cone_friction'] else 'pyramid'} friction")

    return ["", f"Label fidelity: the same candidates labelled with a converged reference ({settings(ref)}: "
            f"{ref['label_trials_per_s_per_core']} trials/s/core, success rate {ref['success_rate']:.3f}). Noise "
            f"floor: moving every candidate by {floor['jitter_m'] * 1e6:.0f} um changes "
            f"{1 - floor['agreement_with_default']:.1%} of the default's labels.", "", *table(
                ["settings", "label trials/s/core", "success rate", "labels equal to the reference"],
                [[f"{row['settings']} ({settings(row)})", row["label_trials_per_s_per_core"],
                  f"{row['success_rate']:.3f}", f"{row['agreement_with_reference']:.1%}"] for row in fid["rows"]])]


def similar_section(r: dict) -> list[str]:
    return [f"## Similar-shape filter: {provenance(r)}", "", *table(
        ["codes", "bits", "radius", "clusters", "seconds (1 core)", "all-pairs baseline (est.)", "speedup"],
        [[f"{r['codes']:,}", r["code_bits"], r["radius"], f"{r['clusters']:,}", r["seconds"],
          f"{r['all_pairs_seconds_estimated']:,} s", f"{r['speedup']:,}x"]]), "",
        f"Target: {r['target_seconds']} s ({r['seconds']} s: {met(-r['seconds'], -r['target_seconds'])})."]


def storage_section(r: dict, experiment: dict | None) -> list[str]:
    b = r["bytes_per_grasp"]
    rows = [["ours: Zarr, blosc zstd, points float16", f"{b['zarr']:,}", "1x"],
            ["one float32 .npy cloud per grasp (+ one .npy per other array)", f"{b['per_grasp_npy']:,}",
             f"{r['ratio_npy_over_zarr']}x"],
            ["one uncompressed numpy archive (float32)", f"{b['uncompressed_npz']:,}", f"{r['ratio_npz_over_zarr']}x"]]
    lines = [f"## Storage per grasp: {provenance(r)}", "", f"The {r['grasps']} labelled grasps of a job on "
             "pybullet:named, written three ways in one run (no target: a comparison).", "",
             *table(["layout", "bytes per grasp", "vs ours"], rows)]
    if experiment:
        a, one = experiment["arms"][0], experiment["arms"][1]
        lines += ["", f"All-objects versus one-object labelled data (`{experiment['command'].strip()}`, "
                  f"{experiment['date']}, docs/paper_experiment.md): arm A {a['labelled_bytes'] / 1e6:.2f} MB "
                  f"({a['labelled_grasps']} grasps), arm {one['arm']} {one['labelled_bytes'] / 1e6:.2f} MB "
                  f"({one['labelled_grasps']} grasps); whole datasets {a['dataset_bytes'] / 1e6:.2f} MB and "
                  f"{one['dataset_bytes'] / 1e6:.2f} MB (the paper: 43.7 GB versus 6.9 GB)."]
    if r.get("compressor_sweep"):
        sweep = sorted(r["compressor_sweep"], key=lambda s: s["bytes_per_grasp"])
        lines += ["", "Compressor and chunk choice, same arrays ('auto' = per dtype as store/codecs.py: bit-shuffle "
                  "for bytes, none for float16, byte-shuffle for wider types; **bold** = store/codecs.py):", "", *table(
                      ["codec", "level", "shuffle", "chunk rows", "bytes/grasp", "write s", "read s"],
                      [[_bold(s, s["codec"]), s["level"], s["shuffle"], s["chunk_rows"], s["bytes_per_grasp"],
                        s["write_s"], s["read_s"]] for s in sweep])]
    return lines


def _bold(row: dict, text: str) -> str:
    return f"**{text}**" if row.get("ours") else text


def candidates_section(r: dict) -> list[str]:
    g, prof = r["generation"], r["extract_profile"]
    parts = prof["seconds_by_part"]
    rate, target = g["candidates_per_s_per_core"], r["target_candidates_per_s_per_core"]
    return [f"## Candidate generation and extraction overhead: {provenance(r)}", "",
            f"{r['object']}, {g['surface_points']:,} surface points, one core (single-threaded BLAS).", "",
            f"Candidate generation (antipodal sampling, open-gripper collision check): {g['candidates']:,} "
            f"candidates from {g['poses_tested']:,} poses in {g['seconds']} s (median of {g.get('repeats', 1)} runs): "
            f"{rate:,} candidates/s/core (target "
            f"{target:,}: {met(rate, target)}). The collision check alone, on {g['collision_check_poses']:,} raw "
            f"poses ({g['colliding_share']:.0%} colliding): {g['collision_check_speedup_vs_per_pose']}x the "
            "per-pose check it replaced (same run, same answers).", "",
            f"Profile of one object's extraction ({prof['candidates']:,} candidates, {prof['grasps']:,} grasps "
            f"kept, cProfile): {prof['seconds']} s, {prof['candidates_per_s_per_core']} candidates/s/core.", "",
            *table(["part", "seconds", "share"], [[name, sec, f"{sec / prof['seconds']:.0%}"]
                                                  for name, sec in parts.items()]), "",
            "Parts: sampling (core/sampling.py: ray casting, poses, collision check), physics (sim/: the closing "
            "and settling trials in pybullet), crops (core/voxel.py: codes at the settled and the candidate pose, "
            "the settled crop's points), rest (loading, writing, bookkeeping).", *_label_lines(r)]


def _label_lines(r: dict) -> list[str]:
    lab, t = r.get("label_profile"), r.get("targets", {})
    if not lab:
        return []
    setup, ratio = lab["setup_share"], lab["rate_over_protocol"]
    return ["", f"Label stage on the one object ({lab['patches']} patches of a 4-object job, "
            f"{lab['trials_per_patch']} trials each, one core, cProfile): {lab['ms_per_patch']} ms per patch, of "
            f"which the trials {lab['trials_ms_per_patch']} ms; set-up around them {setup:.1%} of the time (target "
            f"below {t['label_setup_share']:.0%}: {met(-setup, -t['label_setup_share'])}). "
            f"{lab['label_trials_per_s_per_core']} label trials/s/core, {ratio:.2f} of the protocol's "
            f"{lab['protocol_label_trials_per_s_per_core']}/s on whole objects "
            f"(target {t['label_rate_over_protocol']}: {met(ratio, t['label_rate_over_protocol'])}): a trial on a "
            "patch (a compound of convex pieces) costs more physics than on a whole object; the set-up is not where "
            "the time goes."]


def train_section(r: dict) -> list[str]:
    """One device's training throughput: store path against in-memory tensors, each row with its target."""
    gpu = r["device"] == "cuda"
    rows = []
    for run in r["runs"]:
        store = run["store"]["samples_per_s"]
        if gpu:
            goal = r["targets"]["pointnet_store_samples_per_s_gpu"]
            target = f">= {goal:,}/s: {'met' if store >= goal else 'not met'}" if run["model"] == "pointnet" else "-"
        else:
            goal = r["targets"]["store_over_memory_cpu"]
            target = f">= {goal}: {'met' if run['store_over_memory'] >= goal else 'not met'}"
        rows.append([run["model"], run["batch"], run["precision"], run["loader_workers"],
                     f"{run['in_memory']['samples_per_s']:,}", f"{store:,}", run["store_over_memory"], target])
    reader = ", ".join(f"{x['model']} batch {x['batch']}: {x['samples_per_s']:,}/s" for x in r["reader_only"])
    return [f"## Training throughput ({'GPU' if gpu else 'CPU'}): {provenance(r)}", "", *table(
        ["model", "batch", "precision", "loader workers", "in memory (samples/s)", "from the store (samples/s)",
         "store / memory", "target"], rows), "",
        f"Full training steps (forward, backward, Adam) on {r['rows']:,} synthetic labelled grasps "
        f"({r['points']}-point float16 clouds, random, so they compress worse than real ones). 'In memory': the same "
        "tensors held in host memory, random batches gathered there; 'from the store': the Zarr dataset through "
        "the DataLoader with our reader (`__getitems__` per batch, `ChunkBatchSampler`). The reader alone, "
        f"no training step: {reader}."]


def assembly_scaling_section(r: dict) -> list[str]:
    """The assemble stage on 1 and 2 workers (patches cut on the worker pool, issue 43)."""
    runs = " / ".join(f"{x['workers']} worker{'s' if x['workers'] > 1 else ''} {x['assemble_seconds']:.1f} s"
                      for x in r["runs"])
    return ["## Assembly on the worker pool", "", provenance(r), "",
            f"{r['spec']}: {r['patches']:,} patches. The workers cut the patches (clip the representative's pieces, "
            "cut its surface points), the central actor lays them out, checks the codes and corridors and commits. "
            f"Assemble stage, in run order: {runs}. Speed-up at 2 workers: {r['speedup_2_workers']:.2f}x (target "
            f"{r['target']}x: {met(r['speedup_2_workers'], r['target'])}). The central part (hull meshes, the "
            "fidelity crops, the corridor check, the point grid, the commit) is most of the stage and runs on one "
            "core."]


def render() -> str:
    from benchmarks.pages.experiment_sections import static_section, variants_section
    from benchmarks.pages.scaling_page import scaling_section

    sections = [("bench_end_to_end", lambda r: end_to_end_section(r, load("sim"))),
                ("candidates", candidates_section),
                ("dedup", dedup_section), ("bench_merge", merge_section), ("sim", sim_section),
                ("scaling", scaling_section), ("similar", similar_section),
                ("static_extraction", static_section),
                ("experiment_b_variants", lambda r: variants_section(r, RESULTS)),
                ("assembly_scaling", assembly_scaling_section), ("suite", suite_section)]
    lines = ["# Performance", "", "Generated by `benchmarks/pages/report.py` from `benchmarks/results/*.json`; refresh "
             "everything with `scripts/dev bench`. Each section names the command, date and machine of its run.", ""]
    missing = []
    for name, section in sections:
        result = load(name)
        if result is None:
            missing.append(name)
            continue
        lines += [*section(result), ""]
    for name in ("train_cpu", "train_gpu"):
        result = load(name)
        if result is None:
            missing.append(name)
        else:
            lines += [*train_section(result), ""]
    storage = load("storage")
    if storage:
        lines += [*storage_section(storage, load("paper_experiment")), ""]
    else:
        missing.append("storage")
    if missing:
        lines += [f"Not run yet: {', '.join(missing)}.", ""]
    return "\n".join(lines)
