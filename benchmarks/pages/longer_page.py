"""docs/NAME_longer*.md: the paper experiment's arms trained longer, rendered from their committed results
(benchmarks/results/NAME_longer*.json, written by the script benchmarks/experiment_longer.py, since replaced by a
study's ``training.steps`` on any trainer actor, a GPU one included). Standard library only."""

from __future__ import annotations

from benchmarks.pages.committed import fill
from onepiece_dist.study.markdown import in_words


def longer_name(out: dict) -> str:
    """The stem of the results file and page of ``out``: NAME_longer, or NAME_longer_TAG."""
    return f"{out['source']}_longer" + (f"_{out['tag']}" if out.get("tag") else "")


def decide(out: dict) -> dict:
    """Which B arms' held-out top-1 lies within A's interval (or above) at the larger budget, and each B against
    the R of its radius (AP and top-1)."""
    arms = {a["arm"]: a["heldout"] for a in out["arms"]}
    low = arms["A"]["top1"]["ci95"][0]
    pairs = {name: {"b_ap": held["ap"]["mean"], "r_ap": arms["R" + name[1:]]["ap"]["mean"],
                    "b_top1": held["top1"]["mean"], "r_top1": arms["R" + name[1:]]["top1"]["mean"]}
             for name, held in arms.items() if name.startswith("B") and "R" + name[1:] in arms}
    return {"a_top1_low": low, "qualifying_b": [n for n in pairs if arms[n]["top1"]["mean"] >= low],
            "b_at_least_r": {n: p["b_ap"] >= p["r_ap"] for n, p in pairs.items()}, "pairs": pairs}


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def _cell(held: dict, ap_ci: list | None) -> list[str]:
    top1 = f"{_pct(held['top1'])} [{_pct(held['top1_ci95'][0])}, {_pct(held['top1_ci95'][1])}]"
    return [top1, f"{held['ap']:.3f}" + (f" [{ap_ci[0]:.3f}, {ap_ci[1]:.3f}]" if ap_ci else "")]


def page(out: dict) -> str:
    """docs/NAME_longer.md, rendered from the results of ``report``."""
    samples, cpu_samples = out["steps"] * out["batch_size"], out["cpu_steps"] * out["cpu_batch"]
    rows = []
    for a in out["arms"]:
        held = a["heldout"]
        longer = {"top1": held["top1"]["mean"], "top1_ci95": held["top1"]["ci95"], "ap": held["ap"]["mean"]}
        steps = sorted(s["best_step"] for s in held["seeds"])
        rows.append("| " + " | ".join([a["arm"], f"{a['labelled_grasps']:,}",
                                       *_cell(a["cpu_heldout"], a["cpu_heldout"]["ap_ci95"]),
                                       *_cell(longer, held["ap"]["ci95"]), f"{held['ap']['std']:.3f}",
                                       f"{a['learning_rate']:g}", f"{steps[len(steps) // 2]:,}"]) + " |")
    return fill("longer", times=f"{samples / cpu_samples:g}", command=out["command"], date=out["date"],
                device=out["device"], name=longer_name(out), source=out["source"], cpu_steps=out["cpu_steps"],
                cpu_batch=out["cpu_batch"], cpu_samples=f"{cpu_samples:,}", arms=_names(out),
                steps=f"{out['steps']:,}", batch_size=out["batch_size"], samples=f"{samples:,}",
                heldout_objects=out["heldout"]["objects"], heldout_grasps=f"{out['heldout']['grasps']:,}",
                heldout_rate=_pct(out["heldout"]["positive_rate"]), rate_rule=_rate_rule(out),
                evaluations=out["evaluations"], seeds=len(out["arms"][0]["heldout"]["seeds"]),
                point_step_mm=out["point_step_mm"], rows="\n".join(rows), verdict="\n".join(_verdict(out)))


def _names(out: dict) -> str:
    return in_words([a["arm"] for a in out["arms"]])


def _rate_rule(out: dict) -> str:
    if all(len(a["search"]) == 1 and a["learning_rate"] == a["cpu_learning_rate"] for a in out["arms"]):
        return "each arm at the learning rate its validation split picked in the 2-core run"
    rates = sorted({p["learning_rate"] for a in out["arms"] for p in a["search"]})
    return (f"each arm at the learning rate of seed 0's lowest validation loss among "
            f"{', '.join(f'{r:g}' for r in rates)}")


def _verdict(out: dict) -> list[str]:
    d = decide(out)
    qualifying = ", ".join(d["qualifying_b"]) or "none"
    controls = ", ".join(a["arm"] for a in out["arms"] if a["arm"].startswith("R")
                         and a["heldout"]["top1"]["mean"] >= d["a_top1_low"]) or "none"
    lines = [f"- **B within A's interval (top-1 from {_pct(d['a_top1_low'])}):** {qualifying}.",
             f"- **R (a random subset labelled on its own objects) within A's interval:** {controls}."]
    for name, p in d["pairs"].items():
        held = "holds" if d["b_at_least_r"][name] else "does not hold"
        lines.append(f"- **{name} at least as good as R{name[1:]} (AP):** {held}: {p['b_ap']:.3f} against "
                     f"{p['r_ap']:.3f} (top-1 {_pct(p['b_top1'])} against {_pct(p['r_top1'])}).")
    changed = [a["arm"] for a in out["arms"] if abs(a["heldout"]["ap"]["mean"] - a["cpu_heldout"]["ap"]) > 0.02]
    lines.append(f"- **The larger budget moves AP by more than 0.02 for:** {', '.join(changed) or 'no arm'}.")
    rising = [a["arm"] for a in out["arms"]
              if sorted(s["best_step"] for s in a["heldout"]["seeds"])[len(a["heldout"]["seeds"]) // 2] == out["steps"]]
    lines.append("- **Still improving at the last step (median best checkpoint is the last one):** "
                 + (", ".join(rising) + ": a longer run could move them further." if rising else "no arm."))
    return lines
