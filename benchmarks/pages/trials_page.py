"""The label-rule and analytic-score figures of docs/trials.md, rendered from benchmarks/results/label_rules.json
and closure.json by benchmarks/pages/report.py (never typed)."""

from __future__ import annotations

from pathlib import Path

from benchmarks.pages.committed import render_block

PAGE = Path(__file__).resolve().parents[2] / "docs" / "trials.md"
START = "<!-- label rules: rendered by benchmarks/pages/report.py from benchmarks/results/label_rules.json -->"
END = "<!-- end of label rules -->"


def label_rules_block(r: dict) -> str:
    rate = r["positive_rate"]
    slips = " / ".join(f"{rate[f'nominal_slip_below_{mm}mm']:.1%}" for mm in (5, 10, 20))
    first, last = r["objects"].split("[")[1].rstrip("]").split(":")
    return "\n".join([START, f"`python -m benchmarks.experiments.label_rules` ({r['date']}) labels the paper "
                      f"experiment's held-out objects (random_urdfs {first}-{int(last) - 1}, "
                      f"{r['candidates_per_object']} normal-sampler "
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


CLOSURE_START = "<!-- closure: rendered by benchmarks/pages/report.py from benchmarks/results/closure.json -->"
CLOSURE_END = "<!-- end of closure -->"


def closure_block(r: dict) -> str:
    def verdict(name: str) -> str:
        return "met" if r[name] >= r["targets"][name] else "not met"

    return "\n".join([CLOSURE_START, (
        f"`{r['command']}` ({r['date']}, {r['machine']}, one core): {r['grasps']:,} antipodal candidates on "
        f"`{r['objects']}`. Force closure (pad contacts and the smallest level of graspnetAPI's sweep): "
        f"{r['force_closure_per_s']:,.0f} grasps/s against {r['reference_force_closure_per_s']:,.0f} for the "
        f"reference run beside it (the same contacts found and scored one grasp at a time, dex-net's test per level; "
        f"{r['force_closure_per_s'] / r['reference_force_closure_per_s']:.1f}x), target "
        f"{r['targets']['force_closure_per_s']:,}: {verdict('force_closure_per_s')}; the levels equal the "
        f"reference's for {r['levels_equal_to_reference']:.1%} of grasps. Ferrari-Canny epsilon at mu 0.5 (soft "
        f"fingers, 8 facets, one 6-D hull per grasp): {r['epsilon_per_s']:,.0f}/s "
        f"(reference {r['reference_epsilon_per_s']:,.0f}/s). Robust epsilon ({r['robust_samples']} perturbations, "
        f"{r['robust_grasps']} grasps): {r['robust_epsilon_per_s']:,.1f}/s, target "
        f"{r['targets']['robust_epsilon_per_s']}: {verdict('robust_epsilon_per_s')}{robust_detail(r)}."),
        CLOSURE_END])


def robust_detail(r: dict) -> str:
    """The robust epsilon against its reference and the hulls' own time (results from 2026-12-02 on)."""
    if "hull_ms" not in r:
        return ""
    return (f" (reference, one grasp and one perturbation at a time with qhull's defaults, on "
            f"{r['reference_robust_grasps']} grasps: {r['reference_robust_epsilon_per_s']:,.1f}/s). One wrench hull "
            f"alone takes {r['hull_ms']:.3f} ms here, so 25 exact hulls per grasp cap any robust epsilon that "
            f"computes them at {r['robust_ceiling_per_s']:,.0f}/s on this core: the target needs a cheaper exact "
            f"epsilon than a 6-D hull per sample")


def render_trials_page() -> str:
    text = render_block(PAGE, START, END, "label_rules", label_rules_block)
    return render_block(PAGE, CLOSURE_START, CLOSURE_END, "closure", closure_block, text=text)
