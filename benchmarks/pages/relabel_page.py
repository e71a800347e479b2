"""docs/relabel.md from the committed relabelling of ACRONYM's example mug (results/relabel_acronym.json,
benchmarks/experiments/relabel_acronym.py): the page's figures are rendered, never typed."""

from __future__ import annotations

import math

NAMES = {"ours_vhacd": "our protocol, VHACD pieces", "ours_coacd": "our protocol, CoACD pieces",
         "acronym_physics_coacd": "ACRONYM's physics (friction 1, 150 kg/m^3), CoACD pieces"}


def _pct(x: float) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.0f}%"


def render(result: dict) -> str:
    rows = []
    for name, run in result["settings"].items():
        t = run["report"]["overall"]
        dropped = ", ".join(f"{v} {k.removeprefix('dropped_').replace('_', ' ')}" for k, v in run["dropped"].items()
                            if v)
        rows.append(f"| {NAMES[name]} | {t['grasps']} | {_pct(t['their_positive_rate'])} | "
                    f"{_pct(t['our_positive_rate'])} | {_pct(t['agreement'])} | {t['kappa']:.2f} | "
                    f"{_pct(t['ours_given_theirs'])} | {_pct(t['theirs_given_ours'])} | {t['both']} / "
                    f"{t['ours_only']} / {t['theirs_only']} / {t['neither']} | {dropped or 'none'} | "
                    f"{run['seconds']:.0f} |")
    coacd = result["settings"]["ours_coacd"]["report"]["overall"]
    vhacd = result["settings"]["ours_vhacd"]["report"]["overall"]
    return "\n".join([
        "# ACRONYM's grasps, relabelled by our protocol",
        "",
        "<!-- rendered by benchmarks/pages/relabel_page.py from benchmarks/results/relabel_acronym.json; "
        "do not edit -->",
        "",
        f"Source: `{result['source']}` (2,000 Franka Panda grasps on a mug, with ACRONYM's flex label "
        "`object_in_gripper`). Command: `python -m benchmarks.experiments.relabel_acronym --acronym PATH/TO/acronym` "
        "(each row is `onepiece label --grasps FILE` with the settings named).",
        "",
        f"On CoACD's pieces our label agrees with ACRONYM's on **{_pct(coacd['agreement'])}** of the grasps "
        f"(Cohen's kappa {coacd['kappa']:.2f}); of the grasps ACRONYM calls a success, "
        f"{_pct(coacd['ours_given_theirs'])} hold for us, and of those that hold for us "
        f"{_pct(coacd['theirs_given_ours'])} were successes for ACRONYM. On VHACD's pieces: "
        f"{_pct(vhacd['agreement'])} (kappa {vhacd['kappa']:.2f}).",
        "",
        "| setting | grasps | ACRONYM success | ours | agreement | kappa | ours given theirs | theirs given ours "
        "| both / ours only / theirs only / neither | did not hold at all (ours: fail) | seconds |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        *rows,
        "",
        "How to read it: ACRONYM labels with FleX, friction 1 and the object's own density, one closing and a "
        "shake; ours is pybullet with the Panda preset's box fingers, four trials (the nominal pose and three "
        "perturbed) that must all hold. Grasps that start in collision met the object's convex pieces with the "
        "open hand; a decomposition that fills a cavity (a mug's inside) makes a rim grasp collide.",
        ""])
