"""The depth-noise section of docs/picks.md, from results/pick_depth_noise.json
(benchmarks/experiments/pick_depth_noise.py): the shipped planner and top-down with a noisy depth camera, each level
paired over objects against noise of a micrometre, and the planner's ``denoise`` against none at the same noise."""

from __future__ import annotations

from benchmarks.pages.pick_clutter_section import hand_words
from benchmarks.pages.pick_sets import interval, method_of, paired_first_attempts, pct, pooled


def _points(gain: dict) -> str:
    low, high = gain["interval"]
    return f"{100 * gain['mean']:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def _said(gain: dict) -> str:
    """What a paired change shows."""
    low, high = gain["interval"]
    return "lower" if high < 0 else "higher" if low > 0 else "not shown to differ"


def _mm(noise: float) -> str:
    return f"{1000 * noise:g} mm"


def _rate(result: dict, method: str) -> str:
    m = method_of(result, method)
    return f"{pct(m['first_attempt'])} {interval(m['first_attempt_interval'])}"


def noise_section(result: dict, picks: dict | None) -> list[str]:
    clean = {s["name"]: s for s in (picks or {}).get("sets", [])}
    levels = result["levels"]
    rows = [f"| {_mm(lv['noise'])} | {lv.get('denoise', 'none')} | {s['name']} | {_rate(s, 'network')} | "
            f"{_rate(s, 'top_down')} | {_rate(clean[s['name']], 'network') if s['name'] in clean else '-'} |"
            for lv in levels for s in lv["sets"]]
    hand = ", the Franka hand" if result.get("gripper") else ""
    lines = [f"## The planner under a depth camera's noise{hand}: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}.{hand_words(result)} The benchmark renders exact depth; a real "
             "depth camera's is "
             "noisy, about 1-2 mm at 0.5-0.8 m (more at range and on dark or shiny surfaces). The household and "
             "unseen sets judged as above (8 views an object, the shipped network and the planner's defaults, beside "
             "top-down), every pixel of the camera moved along its ray by Gaussian noise (`onepiece pick` spec "
             "`camera.depth_noise`), first attempt; with the planner's `denoise` at `none` and at `auto` (its "
             "default: the noise measured under the support plane (fitted past the camera's crop 5 mm under the "
             "table), the table widened to 3 deviations, the noise's far tail dropped (below that band, and the "
             "specks above it) and each object point moved onto the plane of its nearest, core.cloud.denoise; an "
             "exact view is left as it is; the levels with it were run again when the tail was dropped and when "
             "the noise was measured past the crop, the section below). Each level is paired against noise of a "
             "micrometre, which moves no point to matter but is drawn as every level's is: a view's noise comes "
             "from its stream, so a run without noise plans and checks "
             "from other draws (the benchmark's own run, last column), a difference of its own:", "",
             "| noise | denoise | set | network on the view | top-down | network without noise (above) |",
             "| --- | --- | --- | --- | --- | --- |", *rows, ""]
    for lv in levels:
        net, over = pooled(lv["sets"], "network"), lv["network_vs_top_down"]
        line = (f"{_mm(lv['noise'])}, denoise {lv.get('denoise', 'none')}: household meshes pooled "
                f"{pct(net['first_attempt'])}")
        if "versus_baseline" in lv:
            against = lv["versus_baseline"]["network"]
            line += (f"; against a micrometre's noise, paired over the {against['objects']} meshes, "
                     f"{_points(against)} ({_said(against)}); top-down {_points(lv['versus_baseline']['top_down'])}")
        if "versus_none" in lv:
            line += f"; against `denoise: none` {_points(lv['versus_none'])} ({_said(lv['versus_none'])})"
        lines.append(f"{line}; the network over top-down {_points(over)}.")
    return [*lines, "", *_verdict(levels)]


def raised_never_lowered(gains: list[dict]) -> bool:
    """The denoise rule over paired gains (each with its ``interval``): shown to raise picks at some level (the
    interval above zero) and shown to lower them at none."""
    return any(g["interval"][0] > 0 for g in gains) and not any(g["interval"][1] < 0 for g in gains)


def _verdict(levels: list[dict]) -> list[str]:
    """Whether ``denoise: auto`` stays the planner's default: shown to raise picks at some level, and shown to
    lower them at none."""
    gains = [lv["versus_none"] for lv in levels if "versus_none" in lv and lv["noise"] > 1e-5]
    if not gains:
        return []
    kept = raised_never_lowered(gains)
    return [("`denoise: auto` is **kept** as the planner's default: it raises the first attempt at some noise "
             "level (the interval above zero) and is shown to lower it at no level." if kept else
             "`denoise: auto` is **not kept**: it is shown to raise the first attempt at no noise level, or to "
             "lower it at some.")]


def noise_views_section(result: dict) -> list[str]:
    """results/pick_noise_views.json: planner variants under noise at more views an object, each paired over the
    meshes against the variant it changes (its run's ``against``, else the first variant run)."""
    runs = result["runs"]
    base = runs[0]["variant"]
    rows = [f"| {r['variant']} | {r['commit']} | {_mm(r['noise'])} | {s['name']} | {_rate(s, 'network')} | "
            f"{_rate(s, 'top_down')} |" for r in sorted(runs, key=lambda r: (r["noise"], r["variant"] != base))
            for s in r["sets"]]
    lines = [f"## The planner under noise on {result['views']} views an object, the Franka hand: "
             f"`{result['command']}`", "",
             f"{result['date']}, {result['machine']}.{hand_words(result)} A change to the planner's denoising moves "
             "every later draw of a view (its candidates, its check), so at 8 views an object a few points are lost "
             f"in the reshuffle. The household and unseen sets at {result['views']} views an object, each planner "
             "variant at the commit it ran at (" + "; ".join(f"{name}: {what}" for name, what in
                                                             result.get("variants", {}).items()) + "), first attempt:",
             "",
             "| variant | commit | noise | set | network on the view | top-down |",
             "| --- | --- | --- | --- | --- | --- |", *rows, ""]
    for r in runs:
        was = _against(runs, r, base)
        if was is None:
            continue
        net, top = (paired_first_attempts(r["sets"], was["sets"], m) for m in ("network", "top_down"))
        now, then = (pct(pooled(sets, "network")["first_attempt"]) for sets in (r["sets"], was["sets"]))
        lines.append(f"- {_mm(r['noise'])}, {r['variant']} against {was['variant']}, paired over the {net['objects']} "
                     "meshes: "
                     f"network {_points(net)} ({_said(net)}), pooled {now} against {then}; top-down {_points(top)} "
                     f"({_said(top)}).")
    return [*lines, "", *_variant_verdicts(runs, base)]


def _against(runs: list[dict], run: dict, base: str) -> dict | None:
    """The run ``run``'s variant is paired against: its ``against`` variant's (else ``base``'s) at the same noise;
    None for ``base`` itself or where that was not run."""
    if run["variant"] == base:
        return None
    other = run.get("against", base)
    return next((b for b in runs if b["variant"] == other and b["noise"] == run["noise"]), None)


def _variant_verdicts(runs: list[dict], base: str) -> list[str]:
    """Each later variant against the one it changes (_against), by the denoise rule: kept where the network is
    shown to pick more at some noise and shown to pick less at none."""
    out = []
    for variant in dict.fromkeys(r["variant"] for r in runs if r["variant"] != base):
        pairs = [(r, _against(runs, r, base)) for r in runs if r["variant"] == variant]
        gains = [paired_first_attempts(r["sets"], b["sets"], "network") for r, b in pairs if b is not None]
        kept = raised_never_lowered(gains)
        against = next((b["variant"] for _, b in pairs if b is not None), base)
        out.append(f"{variant.capitalize()} against {against}: **{'kept' if kept else 'not kept'}** (kept where the "
                   "network picks more at some noise, the interval above zero, and is shown to pick less at none).")
    return out
