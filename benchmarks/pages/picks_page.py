"""docs/picks.md from the committed pick benchmark (results/picks.json, benchmarks/experiments/picks.py) and
planning latency (results/plan.json, benchmarks/speed/bench_plan.py): the page's figures are rendered, never
typed."""

from __future__ import annotations

from pathlib import Path

from benchmarks.pages.committed import load

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "picks.md"
LABELS = {"network": "network on the view", "random": "random collision-free candidate",
          "analytic": "antipodal score on the view", "network_full_mesh": "network on full-mesh candidates"}


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _interval(pair) -> str:
    return f"[{_pct(pair[0])}, {_pct(pair[1])}]"


def _method(result: dict, name: str) -> dict:
    return next(m for m in result["methods"] if m["method"] == name)


def headline(picks: dict) -> list[str]:
    household = next(s for s in picks["sets"] if s["name"] == "household")
    net, full = _method(household, "network"), _method(household, "network_full_mesh")
    target, gap_target = picks["targets"]["first_attempt"], picks["targets"]["full_mesh_gap"]
    gap = full["first_attempt"] - net["first_attempt"]
    objects = sum(o["status"] == "ok" for o in household["objects"])
    return [f"On {objects} real household meshes (robosuite's), the network trained by the cheapest plan picks "
            f"**{_pct(net['first_attempt'])}** {_interval(net['first_attempt_interval'])} at the first attempt from "
            f"one depth view and {_pct(net['within_k'])} within {household['spec']['attempts']} attempts. Target "
            f"{_pct(target)}: **{'met' if net['first_attempt'] >= target else 'not met'}**.",
            "",
            f"The same network ranking candidates sampled on the full mesh picks {_pct(full['first_attempt'])}: "
            f"{100 * gap:+.0f} points from the view's {_pct(net['first_attempt'])}. Target: within "
            f"{100 * gap_target:.0f} points: **{'met' if abs(gap) <= gap_target else 'not met'}**. "
            f"{household['verdict'][0].upper()}{household['verdict'][1:]}."]


def method_table(result: dict) -> list[str]:
    k = result["spec"]["attempts"]
    rows = [f"| {LABELS[m['method']]} | {_pct(m['first_attempt'])} {_interval(m['first_attempt_interval'])} | "
            f"{_pct(m['within_k'])} {_interval(m['within_k_interval'])} | {m['views']} |" for m in result["methods"]]
    return ["| chooser | first attempt [95% CI over objects] | within " + str(k) + " | views |",
            "| --- | --- | --- | --- |", *rows]


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
    rows = [f"| {r['object']} | {r['points']} | {r['sampled']} | {r['candidates']} | {r['seconds']['sample']:.3f} | "
            f"{r['seconds']['crop']:.3f} | {r['seconds']['score']:.3f} | {r['seconds']['total']:.3f} | "
            f"{r['baseline_seconds']:.3f} |" for r in plan["rows"]]
    gpu = plan.get("gpu")
    gpu_line = (f"Scoring {plan['candidates']} crops on {gpu['device']}: {1000 * gpu['score_seconds']:.1f} ms (target "
                f"{1000 * plan['targets']['gpu_score_seconds']:.0f} ms: "
                f"{'met' if gpu['score_seconds'] <= plan['targets']['gpu_score_seconds'] else 'not met'})."
                if gpu else "Scoring on a GPU: not measured (no GPU in this run); target 30 ms.")
    return [f"## Planning latency: `{plan['command']}`", "",
            f"{plan['date']}, {plan['machine']}. {plan['candidates']} placements sampled per view; a placement "
            "whose open gripper meets the cloud at every bite and shift, or holds too few points, is never scored. "
            "Baseline: the same candidates cropped and scored one at a time.", "",
            "| scene | points | placements | scored | sample (s) | crop (s) | score (s) | total (s) | baseline (s) |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            f"Median per view: {median:.3f} s against {plan['median_baseline_seconds']:.3f} s one at a time. Target "
            f"{target} s on one core: **{'met' if median <= target else 'not met'}**. {gpu_line}"]


def render_picks_page() -> str:
    picks, plan = load("picks"), load("plan")
    lines = ["# Picks from one camera", "",
             "<!-- Rendered by benchmarks/pages/report.py (benchmarks/pages/picks_page.py) from "
             "benchmarks/results/picks.json and plan.json: do not edit by hand. -->", ""]
    if picks is None:
        lines += ["The pick benchmark has not been run yet: `.venv/bin/python -m benchmarks.experiments.picks`.", ""]
    else:
        lines += [*headline(picks), "", f"## How: `{picks['command']}`", "", _how(picks), ""]
        for result in picks["sets"]:
            lines += [f"## {result['name'].capitalize()} objects: {result['source']}", "",
                      *method_table(result), "", result["verdict"][0].upper() + result["verdict"][1:] + ".", "",
                      "Per object (views picked at the first attempt, within k):", "", *object_table(result), ""]
        lines += ["## Planned grasps", "", "The network's ranked grasps on the view's cloud (the best in green); "
                  "the title says how each attempt ended.", ""]
        lines += [f"![{Path(p).stem}]({Path(p).relative_to('docs')})" for p in picks["pictures"]] + [""]
    if plan is not None:
        lines += [*latency_section(plan), ""]
    return "\n".join(lines)


def _how(picks: dict) -> str:
    t, spec = picks["training"], picks["sets"][0]["spec"]
    trained = (f"The network: `{t['spec']}`, {t['labels']} labels of {t['candidates']} candidates (success rate "
               f"{t['label_success_rate']:.2f}), validation AP {t['validation_ap']:.2f}."
               if t.get("labels") else f"The network: `{t.get('checkpoint')}`.")
    camera = spec["camera"]
    return (f"{picks['date']}, {picks['machine']}. {trained} Each object dropped on a table in a seeded orientation "
            f"and settled; {spec['views']} views per object from a camera {camera['distance'][0]}-"
            f"{camera['distance'][1]} m away at {camera['elevation_deg'][0]:.0f}-{camera['elevation_deg'][1]:.0f} "
            f"degrees elevation ({camera['image_size']} px, {camera['fov_deg']:.0f} degrees); each chooser's ranked "
            f"grasps executed in turn, up to {spec['attempts']}, from the object at rest: pregrasp 5 cm back, "
            f"approach, close, lift and shake, {spec['sim']['label_trials']} trials of which every one must hold "
            "(the protocol: docs/planning.md).")
