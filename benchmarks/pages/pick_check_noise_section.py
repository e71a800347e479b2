"""The check's pose noise or its fingers' friction scaled (benchmarks/experiments/pick_shape_check.py
--noise-scales, --friction-scales): the 8-draw gain of the check's choice at each multiple of the protocol's,
and against the check at the protocol's own."""

from __future__ import annotations

from benchmarks.pages.pick_sets import pct1


def _interval(d: dict, mean: str, interval: str) -> str:
    return f"{100 * d[mean]:+.1f} [{100 * d[interval][0]:+.1f}, {100 * d[interval][1]:+.1f}]"


WORDS = {  # what is scaled: the column's name, the opening sentence, the verdict's words
    "noise": ("the check's pose noise", "The check's first has to hold on the true shape, which differs from the "
              "hull; a grasp that holds on the hull under larger pose noise than the protocol's might be the one "
              "that does. The hull's check with its pose noise (3 mm and 0.05 rad) scaled, its friction noise as it "
              "is", "the protocol's pose noise"),
    "friction": ("the check's finger friction", "Most of the first grasps that fail slip when lifted; a grasp that "
                 "holds on the hull with less friction than the protocol's might be the surer one on the true "
                 "shape. The hull's check with its fingers' friction (0.4) scaled, its noise as it is",
                 "the protocol's friction"),
}


def noise_lines(by_scale: dict, scaled: str = "noise") -> list[str]:
    """Lines of the page (none where the mode has not run): a table by scale of what is ``scaled`` (WORDS),
    number checked and set, and a verdict per scale (kept where the first 3's paired difference over all objects
    lies above zero)."""
    column, opening, against = WORDS[scaled]
    scales = sorted((s for s in by_scale if s != "stored_agree"), key=float)
    if not scales:
        return []
    rows = [f"| {float(s):g}x | {k} | {w} | {pct1(d['checked'])} | {_interval(d, 'gain_by_object', 'gain_interval')} "
            f"| {_interval(d['versus'], 'mean', 'interval')} |"
            for s in scales for k, by_set in by_scale[s].items() for w, d in by_set.items()]
    agree = by_scale.get("stored_agree", {})
    against_what = ("in the same run (which gave the shares the shapes' measure above kept on "
                    + " and ".join(f"{n} {w} views" for w, n in agree.items()) + ")" if agree
                    else "as the shapes' measure above kept it")
    lines = [f"{opening}, each grasp's draws from the same stream as at the protocol's (the same draws), judged as "
             f"above and paired over objects against the check at the protocol's {against_what}:", "",
             f"| {column} | checked | set | the check's first | gain over the network's first [95% CI] "
             f"| against {against} [95% CI] |", "| --- | --- | --- | --- | --- | --- |", *rows, ""]
    for s in scales:
        pooled = by_scale[s]["3"]["all objects"]["versus"]
        verdict = "kept" if pooled["interval"][0] > 0 else "not kept"
        lines += [f"The check's first among the first 3 at {float(s):g}x {against} against 1x, over "
                  f"all objects: {_interval(pooled, 'mean', 'interval')} points: **{verdict}** (kept where that "
                  "interval lies above zero; what is kept is then judged by the benchmark's own executions).", ""]
    return lines
