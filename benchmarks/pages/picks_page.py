"""docs/picks.md from the committed pick benchmark (results/picks.json, benchmarks/experiments/picks.py) and
planning latency (results/plan.json, benchmarks/speed/bench_plan.py): the page's figures are rendered, never
typed."""

from __future__ import annotations

from pathlib import Path

from benchmarks.pages.committed import load
from benchmarks.pages.pick_carried_section import carried_section
from benchmarks.pages.pick_ceiling_section import ceiling_section, ranked_draws_section, reranked_section
from benchmarks.pages.pick_check_section import check_trials_section, panda_check_section
from benchmarks.pages.pick_clearance_section import clearance_section
from benchmarks.pages.pick_clutter_section import clutter_pointer, clutter_section
from benchmarks.pages.pick_curve_section import curve_section, pool_size_lines, rankings_section
from benchmarks.pages.pick_flying_section import drop_section, flying_section, veils_section
from benchmarks.pages.pick_noise_section import noise_section, noise_views_section
from benchmarks.pages.pick_noisy_labels_section import noisy_labels_section
from benchmarks.pages.pick_own_section import own_network_section
from benchmarks.pages.pick_panda_section import Shipped, panda_section
from benchmarks.pages.pick_plan_options_section import plan_options_section
from benchmarks.pages.pick_rank_section import rank_features_section, robust_rank_section, shape_check_section
from benchmarks.pages.pick_relabelled_section import relabelled_section
from benchmarks.pages.pick_score_draws_section import score_draws_section
from benchmarks.pages.pick_sets import (
    HOUSEHOLD_SETS,
    LABELS,
    against,
    failure_table,
    interval,
    method_table,
    pct,
    pooled,
    target_rows,
)
from benchmarks.pages.pick_table_gap_section import more_views_line, table_gap_section
from benchmarks.pages.pick_trials_section import (
    both_section,
    household_labels_section,
    on_policy_section,
    outline_section,
    points_section,
    schedule_section,
    space_section,
    top_down_section,
    top_draws_section,
    unseen_section,
    vessels_section,
)

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "picks.md"


def headline(picks: dict) -> list[str]:
    sets = [s for s in picks["sets"] if s["name"] in HOUSEHOLD_SETS]
    unseen = next((s for s in sets if s["name"] == "unseen"), None)
    net = pooled(sets, "network")
    where = (f"{net['objects']} real household meshes ({len(sets[0]['objects'])} on which every design was chosen "
             f"and {len(unseen['objects'])} unseen, on which nothing was)" if unseen else
             f"{net['objects']} real household meshes")
    check = sets[0]["spec"]["plan"].get("check_first", 0)
    checked = f", its first {check} grasps checked in simulation," if check else ""
    return [f"On {where}, the network (`{picks['training']['checkpoint']}`){checked} picks "
            f"**{against(net['first_attempt'], picks['targets']['first_attempt'])}** "
            f"{interval(net['first_attempt_interval'])} at the first attempt from one "
            f"depth view ({net['views']} views).", "", "| target | figure | |", "| --- | --- | --- |",
            *target_rows(picks["sets"], picks["targets"]), "",
            *(f"{s['name'].capitalize()} set: {s['verdict']}." for s in sets)]


def pool_line(result: dict) -> str:
    """What the oracle says of the view's candidates."""
    views = [v for o in result["objects"] if o["status"] == "ok" for v in o["views"] if v.get("pool_executed")]
    if not views:
        return ""
    executed = sum(v["pool_executed"] for v in views)
    picked = sum(v["pool_picked"] for v in views)
    holding = sum(v["pool_picked"] > 0 for v in views)
    with_top_down = result["spec"]["plan"].get("top_down", False)
    line = (f"The oracle executed all {executed} candidates of {len(views)} views"
            f"{' (the top-down grasps among them)' if with_top_down else ''}: {pct(picked / executed)} of "
            f"them pick, and {holding} of the {len(views)} views ({pct(holding / len(views))}) hold at least one "
            "that picks: the pool's ceiling.")
    if all("top_down" in v["attempts"] for v in views) and not with_top_down:
        either = sum(v["pool_picked"] > 0 or v["attempts"]["top_down"][:1] == [True] for v in views)
        line += (f" With the top-down grasp added to the pool, {either} of the {len(views)} "
                 f"({pct(either / len(views))}).")
    return line


def object_table(result: dict) -> list[str]:
    methods = [m["method"] for m in result["methods"]]
    k = result["spec"]["attempts"]
    rows = []
    for picks in result["objects"]:
        if picks["status"] != "ok":
            rows.append(f"| {picks['name']} | rejected: {picks['reason']} |" + " |" * len(methods))
            continue
        views = picks["views"]
        cells = [f"{sum(v['attempts'][m][:1] == [True] for v in views)}/{len(views)}, "
                 f"{sum(any(v['attempts'][m][:k]) for v in views)}/{len(views)}" for m in methods]
        rows.append(f"| {picks['name']} | {' | '.join(cells)} |")
    return [f"| object | {' | '.join(LABELS[m] for m in methods)} |", "|" + " --- |" * (len(methods) + 1),
            *rows]


def latency_section(plan: dict) -> list[str]:
    target = plan["targets"]["cpu_seconds_per_view"]
    median = plan["median_seconds_per_view"]
    checks = "median_checked_seconds" in plan
    rows = [f"| {r['object']} | {r['points']} | {r['sampled']} | {r['candidates']} | {r['seconds']['sample']:.3f} | "
            f"{r['seconds']['crop']:.3f} | {r['seconds']['score']:.3f} | {r['seconds']['total']:.3f} | "
            f"{r['baseline_seconds']:.3f} |" + (_check_cell(r) if checks else "") for r in plan["rows"]]
    gpu = plan.get("gpu")
    gpu_line = (f"Scoring {plan['candidates']} crops on {gpu['device']}: {1000 * gpu['score_seconds']:.1f} ms (target "
                f"{1000 * plan['targets']['gpu_score_seconds']:.0f} ms: "
                f"{'met' if gpu['score_seconds'] <= plan['targets']['gpu_score_seconds'] else 'not met'})."
                if gpu else "Scoring on a GPU: not measured (no GPU in this run); target 30 ms.")
    return [f"## Planning latency: `{plan['command']}`", "",
            f"{plan['date']}, {plan['machine']}. {plan['candidates']} placements sampled per view; a placement "
            "whose open gripper meets the cloud at every bite and shift, or holds too few points, is never scored. "
            "Baseline: the same candidates cropped and scored one at a time.", "",
            "| scene | points | placements | scored | sample (s) | crop (s) | score (s) | total (s) | baseline (s) |"
            + (" the check (s) |" if checks else ""),
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- |" + (" --- |" if checks else ""), *rows, "",
            f"Median per view: {median:.3f} s against {plan['median_baseline_seconds']:.3f} s one at a time. Target "
            f"{target} s on one core: **{'met' if median <= target else 'not met'}**. {_dense_line(plan)}"
            f"{_checked_line(plan)}{_hands_line(plan)}{_files_line(plan)}{gpu_line}"]


def _files_line(plan: dict) -> str:
    """Several objects on the table from a depth camera's own files (bench_plan.file_scenes), as `onepiece grasp`
    reads them: each view's planning without and with the check, against the same target."""
    files = plan.get("files")
    if not files:
        return ""
    target, rows = plan["targets"]["cpu_seconds_per_view"], files["rows"]
    counts = sorted({len(r["objects"]) for r in rows})
    return (f"Several objects side by side on the table ({' or '.join(map(str, counts))} of the scenes' objects, "
            f"{len(rows)} views), planned from a depth camera's own files as `onepiece grasp` reads them "
            f"(`onepiece scene`'s depth PNG, intrinsics and camera pose; {min(r['points'] for r in rows)}-"
            f"{max(r['points'] for r in rows)} points in the workspace): median "
            f"{files['median_seconds_per_view']:.3f} s a view without the check (the {target} s target: "
            f"**{_met(files['median_seconds_per_view'], target)}**), {files['median_checked_seconds']:.3f} s with "
            f"its first {rows[0]['check_first']} checked (**{_met(files['median_checked_seconds'], target)}**). ")


def _met(seconds: float, target: float) -> str:
    return "met" if seconds <= target else "not met"


def _hands_line(plan: dict) -> str:
    """The same views planned for other hands (bench_plan.HANDS), each with the network shipped for it."""
    target = plan["targets"]["cpu_seconds_per_view"]
    return "".join(
        f"The `{h['hand']}` preset ({h['gripper']}: its own collision test, and its own hand in the check's pick "
        f"world) on the same views with the network shipped for it: median {h['median_seconds_per_view']:.3f} s a "
        f"view without the check, {h['median_checked_seconds']:.3f} s with its first {h['rows'][0]['check_first']} "
        f"checked (the {target} s target: **{'met' if h['median_checked_seconds'] <= target else 'not met'}**). "
        for h in plan.get("hands", []))


def _check_cell(row: dict) -> str:
    if "check_seconds" not in row:
        return " - |"
    return f" {row['check_seconds']:.3f} |" if row["check_plane"] else " no plane |"


def _checked_line(plan: dict) -> str:
    """The planner's default with its check (PlanSpec.check_first): the network's planning and the check."""
    if "median_checked_seconds" not in plan:
        return ""
    row = next(r for r in plan["rows"] if "check_seconds" in r)
    seconds, target = plan["median_checked_seconds"], plan["targets"]["cpu_seconds_per_view"]
    return (f"The planner's default also checks its first {row['check_first']} grasps, each executed "
            f"{row['check_draws']} times in simulation on the shape the view implies (docs/planning.md): with the "
            f"check, median {seconds:.3f} s a view (the {target} s target: "
            f"**{'met' if seconds <= target else 'not met'}**; `--check 0`, the network's order alone, is the figure "
            "above). ")


def _dense_line(plan: dict) -> str:
    if plan.get("dense_seconds") is None:
        return ""
    seconds, target = plan["dense_seconds"], plan["targets"]["dense_seconds"]
    return (f"A 2-million-point cloud, thinned first: {seconds:.2f} s (target {target:g} s: "
            f"**{'met' if seconds <= target else 'not met'}**). ")


# results rendered after the benchmark's, in this order
SECTIONS = ("pick_table_gap", "pick_table_gap_panda", "pick_table_gap_robotiq_2f85", "pick_table_gap_robotiq_2f140",
            "pick_plan_options", "pick_score_draws", "pick_relabelled", "pick_own_network", "pick_own_network_panda",
            "pick_own_network_robotiq_2f85", "pick_own_network_robotiq_2f140", "pick_own_network_panda_urdf",
            "pick_carried", "pick_panda", "pick_panda_check", "pick_clutter_panda",
            "pick_clutter_panda_pile", "pick_clearance_panda",
            "pick_clearance_panda_pile", "pick_ceiling_panda", "pick_clutter", "pick_clutter_pile", "pick_clearance",
            "pick_clearance_pile", "pick_depth_noise", "pick_depth_noise_panda", "pick_noise_views",
            "pick_flying_pixels", "pick_veils", "pick_flying_drop", "pick_noisy_labels", "pick_ceiling",
            "pick_ranked_draws", "pick_reranked", "pick_robust_rank", "pick_rank_features", "pick_shape_check",
            "pick_check_trials", "pick_unseen", "pick_curve", "pick_space", "pick_on_policy", "pick_vessels",
            "pick_top_down", "pick_points",
            "pick_top_down_both", "pick_schedule", "pick_household_labels", "pick_outline", "pick_top_draws",
            "pick_rankings", "pick_pool_size")


def render_picks_page() -> str:
    picks, plan = load("picks"), load("plan")
    shipped_panda = load("pick_panda_2mm")  # the run the Franka hand's shipped network came from: read once
    lines = ["# Picks from one camera", "",
             "<!-- Rendered by benchmarks/pages/report.py (benchmarks/pages/picks_page.py) from "
             f"benchmarks/results/picks.json, {', '.join(f'{name}.json' for name in SECTIONS)}, "
             "pick_panda_2mm.json, pick_panda_50_iterations.json, pick_panda_then.json and plan.json: do not edit by "
             "hand. -->", ""]
    if picks is None:
        lines += ["The pick benchmark has not been run yet: `.venv/bin/python -m benchmarks.experiments.picks`.", ""]
    else:
        lines += [*headline(picks), "", *more_views_line(load("pick_table_gap"), picks["targets"]["first_attempt"]),
                  *clutter_pointer(load("pick_clutter"), load("pick_clearance")), "",
                  f"## How: `{picks['command']}`", "", _how(picks), ""]
        for result in picks["sets"]:
            lines += [f"## {result['name'].capitalize()} objects: {result['source']}", "",
                      *method_table(result), "", result["verdict"][0].upper() + result["verdict"][1:] + ".", "",
                      pool_line(result), "", "First attempts by how they ended:", "", *failure_table(result), "",
                      "Per object (views picked at the first attempt, within k):", "", *object_table(result), ""]
        lines += ["## Planned grasps", "", "The network's ranked grasps on the view's cloud (the best in green); "
                  "the title says how each attempt ended.", ""]
        lines += [f"![{Path(p).stem}]({Path(p).relative_to('docs')})" for p in picks["pictures"]] + [""]
    target = (picks or {}).get("targets", {}).get("first_attempt", 0.85)
    render = {"pick_table_gap": table_gap_section, "pick_table_gap_panda": table_gap_section,
              "pick_table_gap_robotiq_2f85": table_gap_section, "pick_table_gap_robotiq_2f140": table_gap_section,
              "pick_plan_options": lambda r: plan_options_section(r, load("pick_table_gap")),
              "pick_score_draws": score_draws_section,
              "pick_relabelled": lambda r: relabelled_section(r, load("pick_plan_options")),
              "pick_own_network": lambda r: own_network_section(r, target),
              "pick_own_network_panda": lambda r: own_network_section(r, target),
              "pick_own_network_robotiq_2f85": lambda r: own_network_section(r, target),
              "pick_own_network_robotiq_2f140": lambda r: own_network_section(r, target),
              "pick_own_network_panda_urdf": lambda r: own_network_section(r, target),
              "pick_carried": carried_section,
              "pick_panda": lambda r: panda_section(r, picks, load("pick_panda_50_iterations"),
                                                    load("pick_panda_then"), _shipped_panda(shipped_panda)),
              "pick_panda_check": lambda r: panda_check_section(r, shipped_panda),
              "pick_clutter_panda": clutter_section, "pick_clutter_panda_pile": clutter_section,
              "pick_clutter_pile": clutter_section,
              "pick_clearance_panda": clearance_section, "pick_clutter": clutter_section,
              "pick_clearance": clearance_section, "pick_clearance_pile": clearance_section,
              "pick_clearance_panda_pile": clearance_section,
              "pick_depth_noise": lambda r: noise_section(r, picks),
              "pick_depth_noise_panda": lambda r: noise_section(r, _panda_picks(shipped_panda, picks)),
              "pick_noise_views": noise_views_section, "pick_noisy_labels": noisy_labels_section,
              "pick_flying_pixels": flying_section, "pick_veils": veils_section,
              "pick_flying_drop": drop_section,
              "pick_ceiling": lambda r: _ceiling(r, picks),
              "pick_ceiling_panda": lambda r: _ceiling(r, _panda_picks(shipped_panda, picks)),
              "pick_ranked_draws": ranked_draws_section,
              "pick_reranked": lambda r: reranked_section(r, load("pick_rerank_fit")),
              "pick_robust_rank": robust_rank_section, "pick_rank_features": rank_features_section,
              "pick_shape_check": shape_check_section, "pick_check_trials": check_trials_section,
              "pick_unseen": lambda r: unseen_section(r, picks),
              "pick_curve": lambda r: curve_section(r, picks),
              "pick_space": space_section, "pick_on_policy": on_policy_section,
              "pick_vessels": vessels_section, "pick_top_down": top_down_section,
              "pick_points": lambda r: points_section(r, load("pick_top_down")),
              "pick_top_down_both": lambda r: both_section(r, load("pick_top_down")),
              "pick_schedule": lambda r: schedule_section(r, load("pick_top_down")),
              "pick_household_labels": lambda r: household_labels_section(r, load("pick_top_down")),
              "pick_outline": lambda r: outline_section(r, load("pick_top_down")),
              "pick_top_draws": lambda r: top_draws_section(r, load("pick_top_down")),
              "pick_rankings": rankings_section,
              "pick_pool_size": pool_size_lines}
    for name in SECTIONS:
        result = load(name)
        if result is not None:
            lines += [*render[name](result), ""]
    if plan is not None:
        lines += [*latency_section(plan), ""]
    return "\n".join(lines)


def _ceiling(result: dict, picks: dict | None) -> list[str]:
    sets = [s for s in (picks or {}).get("sets", []) if s["name"] in HOUSEHOLD_SETS]
    top_down = pooled(sets, "top_down")["first_attempt"] if sets else None
    return ceiling_section(result, picks, top_down, (picks or {}).get("targets"))


def _shipped_panda(record: dict | None) -> Shipped | None:
    """The run the network shipped for the Franka hand came from (``record``) and that network's picks by today's
    planner."""
    own = load("pick_own_network_panda")
    return None if record is None or own is None else Shipped(record, own["shipped"])


def _panda_picks(result: dict | None, picks: dict | None) -> dict | None:
    """The Franka hand's shipped network (seed 0) judged by the pick benchmark, shaped as results/picks.json's
    sets with ``picks``' targets, for the sections that compare with it."""
    if result is None or not result["points"]:
        return None
    return {"sets": result["points"][0]["sets"], "targets": (picks or {}).get("targets")}


def _check_words(plan: dict) -> str:
    """What the network on the view does before its first attempt (PlanSpec.check_first)."""
    if not plan.get("check_first"):
        return " The network on the view ranks by its score alone."
    return (f" The network on the view checks its first {plan['check_first']} grasps before the first attempt "
            f"(`plan.check_first`): each executed {plan['check_draws']} times by the pick protocol on the shape the "
            f"view implies ({plan.get('check_shape', 'hull')}), reordered by how often they held (below).")


def _gripper_words(training: dict) -> str:
    """Which gripper executes the picks: the one the network was trained for (the shipped network's where the
    results predate the field)."""
    name = training.get("gripper")
    if name is None and training.get("checkpoint") == "onepiece_dist/plan/networks/pick_view.pt":
        from onepiece_dist.plan.scorer import GraspScorer
        from onepiece_dist.plan.shipped import NETWORK

        name = GraspScorer(NETWORK, device="cpu").gripper.name
    if name is None:
        return ""
    what = (" (the default job's: a box palm and box fingers, 8 cm stroke; not the Franka hand's meshes of the "
            "`panda` preset)" if name == "onepiece_box" else "")
    return f" Every grasp is executed by the gripper the network was trained for, `{name}`{what}."


def _how(picks: dict) -> str:
    t, spec = picks["training"], picks["sets"][0]["spec"]
    if t.get("design"):
        pool = f" It plans on {t['pool']}." if t.get("pool") else ""
        trained = (f"The network: `{t['checkpoint']}` (the shipped one), design `{t['design']}`, {t['labels']} pick "
                   f"labels on `{t['training_objects']}` (the learning curve and the trials below).{pool}")
    elif t.get("candidates"):
        trained = (f"The network: `{t['spec']}`, {t['labels']} labels of {t['candidates']} candidates (success rate "
                   f"{t['label_success_rate']:.2f}), validation AP {t['validation_ap']:.2f}.")
    else:
        trained = f"The network: `{t.get('checkpoint')}`."
    camera = spec["camera"]
    return (f"{picks['date']}, {picks['machine']}. {trained}{_gripper_words(t)}{_check_words(spec['plan'])} Each "
            "object dropped on a "
            "table in a seeded orientation "
            f"and settled; {spec['views']} views per object from a camera {camera['distance'][0]}-"
            f"{camera['distance'][1]} m away at {camera['elevation_deg'][0]:.0f}-{camera['elevation_deg'][1]:.0f} "
            f"degrees elevation ({camera['image_size']} px, {camera['fov_deg']:.0f} degrees); each chooser's ranked "
            f"grasps executed in turn, up to {spec['attempts']}, from the object at rest: pregrasp 5 cm back, "
            f"approach, close, lift and shake, {spec['sim']['label_trials']} trials of which every one must hold "
            "(the protocol: docs/planning.md).")
