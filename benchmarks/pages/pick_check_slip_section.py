"""The check's ties broken by the hull's slip in the fingers (benchmarks/experiments/pick_check_slip.py): the
8-draw share of what the rule puts first, against the check without it."""

from __future__ import annotations

from benchmarks.pages.pick_check_noise_section import _interval
from benchmarks.pages.pick_sets import pct1


def slip_lines(summary: dict) -> list[str]:
    """Lines of the page (none where the experiment has not run): by number checked and set, the check's first
    and the tie-broken first judged by their 8 draws on the true object, and the verdict (kept where the first
    3's paired difference over all objects lies above zero)."""
    if not summary:
        return []
    rows = [f"| {k} | {w} | {d['views']} | {pct1(d['first'])} | {pct1(d['checked'])} | "
            f"{_interval(d['versus'], 'mean', 'interval')} | {pct1(d['surest'])} | {d['changed']} |"
            for k in ("3", "5") for w, d in summary[k].items()]
    agree = " and ".join(f"{n} of {summary['3'][w]['views']} {w} views" for w, n in summary["stored_agree"].items())
    pooled = summary["3"]["all objects"]["versus"]
    verdict = "kept" if pooled["interval"][0] > 0 else "not kept"
    return [f"Most of the share the check loses to the surest of its grasps is lost where several held equally often "
            "on the hull, and the network's order decides. Each execution that held also says how far the hull "
            "moved in the fingers while lifted and shaken (its slip). A rule fixed before it was run "
            "(`.venv/bin/python -m benchmarks.experiments.pick_check_slip`): among the grasps that held most often "
            "on the hull, the one whose executions that held slipped least (their mean) goes first; the network's "
            f"order where that ties too. The hull's check at 8 draws measured again, its slips recorded (its shares "
            f"those the shapes' measure above kept on {agree}), judged as above:", "",
            "| checked | set | views | the network's first | the tie-broken first | against the check's first "
            "[95% CI over objects] | the surest (an oracle) | views whose first changed |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            f"The tie-broken first among the first 3 against the check's, over all objects: "
            f"{_interval(pooled, 'mean', 'interval')} points: **{verdict}** (kept where that interval lies above "
            "zero; what is kept is then judged by the benchmark's own executions).", ""]
