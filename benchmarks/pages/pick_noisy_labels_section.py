"""The labels-from-noisy-views section of docs/picks.md, from results/pick_noisy_labels.json
(benchmarks/experiments/pick_noisy_labels.py): the Franka hand's network fitted with its second label batch seen
through a noisy camera, seed for seed against the shipped recipe's, each judged under each noise level as
pick_depth_noise judges the shipped network. The trials' rule over both household sets: kept where the paired
interval at the labels' own noise lies above zero and no level's lies below it."""

from __future__ import annotations

from benchmarks.pages.pick_noise_section import _mm
from benchmarks.pages.pick_sets import loaded_objects, method_of
from onepiece_dist.stats.intervals import PairedGain, paired_gain

VIEWS = 8


def per_object(sets: list[dict]) -> dict[str, int]:
    """set/object -> views picked at the first attempt by the network."""
    return {f"{s['name']}/{o['name']}": sum(list(v["attempts"]["network"][:1]) == [True] for v in o["views"])
            for s, o in loaded_objects(sets)}


def first(sets: list[dict], name: str) -> str:
    found = [s for s in sets if s["name"] == name]
    if not found:
        return "-"
    rate = method_of(found[0], "network")["first_attempt"]
    return f"{100 * rate:.1f}%"


def gains(result: dict) -> dict[float, PairedGain]:
    """noise -> the noisy labels' network against the exact labels', over the seeds judged at both."""
    out = {}
    for noise in sorted({r["noise"] for r in result["levels"]}):
        at = {(r["seed"], r["labels"]): r["sets"] for r in result["levels"] if r["noise"] == noise}
        seeds = sorted(s for s, labels in at if labels == "noisy" and (s, "exact") in at)
        out[noise] = paired_gain([per_object(at[(s, "noisy")]) for s in seeds],
                                 [per_object(at[(s, "exact")]) for s in seeds], VIEWS)
    return out


def _words(gain: PairedGain) -> str:
    low, high = gain.interval
    return f"{100 * gain.gain:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}] over {gain.seeds} seeds"


def verdict(result: dict, found: dict[float, PairedGain]) -> str:
    at_own = found.get(result["noise"])
    if at_own is None or at_own.seeds < 2:
        return "undecided: fewer than two seeds judged at the labels' own noise"
    lower = [n for n, g in found.items() if g.interval[1] < 0]
    if at_own.interval[0] > 0 and not lower:
        return "**kept**: it raises the first attempt at the labels' own noise and is shown to lower it at no level"
    why = ("its interval at the labels' own noise reaches zero" if at_own.interval[0] <= 0 else
           f"it lowers the first attempt at {', '.join(_mm(n) for n in lower)}")
    return f"**not kept**: {why}"


def noisy_labels_section(result: dict) -> list[str]:
    batches = result["batches"]
    rows = [f"| {_mm(r['noise'])} | {r['seed']} | {r['labels']} | {first(r['sets'], 'household')} | "
            f"{first(r['sets'], 'unseen')} |"
            for r in sorted(result["levels"], key=lambda r: (r["noise"], r["seed"], r["labels"]))]
    found = gains(result)
    lines = [f"## Labels from noisy views, the Franka hand: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. The networks learn from exact renders, and a depth camera's "
             "noise still costs the Franka hand's planner with denoising (above). The second label batch of the "
             f"network shipped for that hand ({batches[1]['objects']}: the same objects, views and seeds) labelled "
             f"again from views with {_mm(result['noise'])} of depth noise, denoised as the planner denoises "
             f"({batches[1]['labels']} labels, success rate {batches[1]['success_rate']:.2f}); `context_balanced` "
             f"fitted on the first batch (exact views, {batches[0]['labels']} labels) joined with it, seed for seed "
             "against the shipped recipe's networks (the second batch from exact views), each judged as the noise "
             "section above judges the shipped one (household and unseen sets, 8 views an object, the planner's "
             "defaults of that day: its denoising before the noise's far tail was dropped, above), network first "
             "attempt:", "",
             "| noise | seed | second batch's views | household | unseen |", "| --- | --- | --- | --- | --- |", *rows,
             "", "The noisy labels' network against the exact labels', paired over the 28 meshes (each object's "
             "rate averaged over the seeds):", ""]
    lines += [f"- {_mm(noise)}: {_words(gain)}" for noise, gain in found.items()]
    return [*lines, "", f"Labels from noisy views: {verdict(result, found)} (kept where the interval at the labels' "
            "own noise lies above zero and no level's lies below it)."]
