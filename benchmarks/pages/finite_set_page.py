"""docs/finite_set.md and its plot, rendered from benchmarks/results/finite_set.json
(benchmarks/experiments/finite_set.py measures it)."""

from __future__ import annotations

from pathlib import Path


def _curve_name(curve: dict) -> str:
    return f"{curve['resolution_mm']:g} mm" + (f", radius {curve['radius']}" if curve["radius"] else ", exact")


def _fit_words(f: dict) -> str:
    p, s = f["power_law"], f["saturation"]
    words = [f"power law exponent {p['exponent']:.3f} (predicts {p['predicted']:,.0f}"
             + _holdout(p, "") + ")"]
    if "u_max" in s:
        words.append(f"saturation U_max {s['u_max']:,.0f}, half at {s['half_objects']:,.0f} objects (predicts "
                     f"{s['predicted']:,.0f}" + _holdout(s, "") + ")")
    else:
        words.append("no saturating curve fits")
    return "; ".join(words) + f"; better: {f['better_fit']} (by {f['judged_by']})"


def _holdout(model: dict, _: str) -> str:
    guess = model.get("largest_predicted_from_the_rest")
    return "" if guess is None else f"; fitted without the largest size it predicts {guess:,.0f} there"


def page_text(out: dict) -> str:
    """docs/finite_set.md from the results: every figure is the JSON's."""
    exact = next(c for c in out["curves"] if c["resolution_mm"] == 10 and c["radius"] == 0)
    last = exact["rows"][-1]
    lines = ["# Is the set of in-gripper shapes finite?", "",
             f"Command: `{out['command']}` ({out['date']}, {out['machine']}). Rendered from "
             "benchmarks/results/finite_set.json by benchmarks/pages/finite_set_page.py.", "",
             f"One extraction job: {out['objects_ok']} objects (`{out['objects_source']}`, {out['rejected']} rejected) "
             f"x {out['grasps_per_object']} candidates from the paper's normal-direction sampler, each settled in "
             f"pybullet and cropped at its settled pose: {out['grasps']:,} grasps in "
             f"{out['extraction_core_seconds']:,.0f} core-seconds ({out['extraction_wall_seconds']:,.0f} s wall in "
             f"this run, which reused {out.get('objects_reused', 0)} objects' parts of an earlier one). "
             f"Unique codes among the grasps of the first N objects, mean [min, max] over {out['orders']} seeded "
             "object orders; 5 and 20 mm codes crop the same settled poses again from each object's stored surface "
             "points.", "",
             f"**At 10 mm (the network's resolution), exact codes:** {last['unique_mean']:,.0f} unique codes among "
             f"{last['objects']} objects; {exact['fit']['new_codes_per_object_at_end']:,.1f} new codes per object "
             f"added at the end. Fitted: {_fit_words(exact['fit'])}.", "",
             "![unique codes against objects](finite_set.png)", "",
             "| code | bits | " + " | ".join(f"{r['objects']} obj." for r in exact["rows"]) + " | power-law exponent | "
             f"predicted at {out['predict_at']:,} (power law) | saturation U_max | better fit |",
             "| --- | ---: | " + " | ".join("---:" for _ in exact["rows"]) + " | ---: | ---: | ---: | --- |"]
    for c in out["curves"]:
        f = c["fit"]
        u_max = f"{f['saturation']['u_max']:,.0f}" if "u_max" in f["saturation"] else "-"
        lines.append(f"| {_curve_name(c)} | {c['code_bits']} | "
                     + " | ".join(f"{r['unique_mean']:,.0f} [{r['unique_min']:,}, {r['unique_max']:,}]"
                                  for r in c["rows"])
                     + f" | {f['power_law']['exponent']:.3f} | {f['power_law']['predicted']:,.0f} | {u_max} | "
                       f"{f['better_fit']} |")
    lines += ["", "## What it says", ""]
    for c in out["curves"]:
        lines.append(f"- {_curve_name(c)}: {_fit_words(c['fit'])}; "
                     f"{c['fit']['new_codes_per_object_at_end']:,.1f} new codes per added object at the end.")
    lines += ["", "A power-law exponent near 1 means every object brings about as many new shapes as the one before "
              "(no finite set at this size); well below 1, shapes repeat more and more but the set still grows; "
              "a saturation fit that beats it, with its U_max not far above the counts seen, is what a finite set "
              "looks like.", ""]
    return "\n".join(lines)


def write_page(out: dict, path: Path) -> None:
    path.write_text(page_text(out))


def plot(out: dict, path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for c in out["curves"]:
        n = [r["objects"] for r in c["rows"]]
        ax.errorbar(n, [r["unique_mean"] for r in c["rows"]],
                    yerr=[[r["unique_mean"] - r["unique_min"] for r in c["rows"]],
                          [r["unique_max"] - r["unique_mean"] for r in c["rows"]]], fmt="o-", capsize=3,
                    label=_curve_name(c))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("objects")
    ax.set_ylabel("unique codes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
