"""The label-rule figures of docs/trials.md, rendered from benchmarks/results/label_rules.json by
benchmarks/report.py (never typed)."""

from __future__ import annotations

from pathlib import Path

from report import render_block

PAGE = Path(__file__).resolve().parents[1] / "docs" / "trials.md"
START = "<!-- label rules: rendered by benchmarks/report.py from benchmarks/results/label_rules.json -->"
END = "<!-- end of label rules -->"


def label_rules_block(r: dict) -> str:
    rate = r["positive_rate"]
    slips = " / ".join(f"{rate[f'nominal_slip_below_{mm}mm']:.1%}" for mm in (5, 10, 20))
    first, last = r["objects"].split("[")[1].rstrip("]").split(":")
    return "\n".join([START, f"`python benchmarks/label_rules.py` ({r['date']}) labels the paper experiment's held-out "
                      f"objects (random_urdfs {first}-{int(last) - 1}, {r['candidates_per_object']} normal-sampler "
                      f"candidates each, K = {r['label_trials']}, the default physics) and reads each rule's positive "
                      f"rate off the same {r['held_grasps']:,} held grasps: nominal {rate['nominal']:.1%}, every "
                      f"trial {rate['every_trial']:.1%}, at least half of the trials {rate['half_the_trials']:.1%}; "
                      f"the nominal trial with the object slipping less than 5 / 10 / 20 mm in the hand {slips}."
                      + payload_sentence(r), END])


def payload_sentence(r: dict) -> str:
    """The positive rates with a payload at the grasp centre (``sim.load: grasp``), one per payload mass."""
    loads = r.get("grasp_load")
    if not loads:
        return ""
    rates = "; ".join(f"{mass} kg: nominal {v['positive_rate']['nominal']:.1%}, every trial "
                      f"{v['positive_rate']['every_trial']:.1%}" for mass, v in loads.items())
    return f" With the label trials lifting a payload at the grasp centre (`sim.load: grasp`) instead: {rates}."


def render_trials_page() -> str:
    return render_block(PAGE, START, END, "label_rules", label_rules_block)
