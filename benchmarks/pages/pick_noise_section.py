"""The depth-noise section of docs/picks.md, from results/pick_depth_noise.json
(benchmarks/experiments/pick_depth_noise.py): the shipped planner and top-down with a noisy depth camera, each level
paired over objects against the benchmark's run without noise."""

from __future__ import annotations

from benchmarks.pages.pick_sets import interval, method_of, pct, pooled


def _points(gain: dict) -> str:
    low, high = gain["interval"]
    return f"{100 * gain['mean']:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def _said(gain: dict) -> str:
    """What a paired change against the run without noise shows."""
    low, high = gain["interval"]
    return "lower" if high < 0 else "higher" if low > 0 else "not shown to differ"


def noise_section(result: dict, picks: dict | None) -> list[str]:
    clean = {s["name"]: s for s in (picks or {}).get("sets", [])}
    rows = []
    for lv in result["levels"]:
        for s in lv["sets"]:
            was = clean.get(s["name"])
            rows.append(f"| {_mm(lv['noise'])} | {s['name']} | "
                        + " | ".join(f"{pct(method_of(s, m)['first_attempt'])} "
                                     f"{interval(method_of(s, m)['first_attempt_interval'])}"
                                     for m in ("network", "top_down"))
                        + f" | {pct(method_of(was, 'network')['first_attempt']) if was else '-'} |")
    lines = [f"## The planner under a depth camera's noise: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. The benchmark renders exact depth; a real depth camera's is "
             "noisy, about 1-2 mm at 0.5-0.8 m (more at range and on dark or shiny surfaces). The household and "
             "unseen sets judged as above (8 views an object, the shipped network and the planner's defaults, beside "
             "top-down), every pixel of the camera moved along its ray by Gaussian noise (`onepiece pick` spec "
             "`camera.depth_noise`), first attempt. Each level is paired against noise of a micrometre, which moves "
             "no point to matter but is drawn as every level's is: a view's noise comes from its stream, so a run "
             "without noise plans and checks from other draws (the benchmark's own run, last column), a difference "
             "of its own:", "",
             "| noise | set | network on the view | top-down | network without noise (above) |",
             "| --- | --- | --- | --- | --- |", *rows, ""]
    for lv in result["levels"]:
        net, over = pooled(lv["sets"], "network"), lv["network_vs_top_down"]
        line = f"{_mm(lv['noise'])}: household meshes pooled {pct(net['first_attempt'])}"
        if "versus_baseline" in lv:
            against = lv["versus_baseline"]["network"]
            line += (f"; against a micrometre's noise, paired over the {against['objects']} meshes, "
                     f"{_points(against)} ({_said(against)}); top-down {_points(lv['versus_baseline']['top_down'])}")
        lines.append(f"{line}; the network over top-down {_points(over)}.")
    return lines


def _mm(noise: float) -> str:
    return f"{1000 * noise:g} mm"
