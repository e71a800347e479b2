"""The figures of docs/assembly.md (the default job's, and the CPU-independence check's), rendered from
benchmarks/results/default_job.json and cpu_independence.json by benchmarks/pages/report.py (never typed)."""

from __future__ import annotations

from pathlib import Path

from benchmarks.pages.committed import render_block
from onepiece_dist.study.markdown import provenance, table

PAGE = Path(__file__).resolve().parents[2] / "docs" / "assembly.md"
FIGURES_START = "<!-- figures: rendered by benchmarks/pages/report.py from benchmarks/results/default_job.json -->"
FIGURES_END = "<!-- end of figures -->"


def default_job_figures(r: dict) -> str:
    """The figures section of docs/assembly.md, from the default job's results."""
    a, labels = r["assembly"], r["labels"] or {}
    size = " x ".join(f"{x:.2f}" for x in a["bounding_box_m"])
    ratio = a["label_trials_one_object"] / max(a["label_trials_all_grasps"], 1)
    cost = (f"the one object costs {ratio:.1f}x more" if ratio > 1 else f"the one object costs {1 / ratio:.1f}x less")
    points = ", points" if r["every_grasp_points"] else "; points only for the representatives, in unique/points"
    chamfer = (f"{a['chamfer_mm']:.2f} mm mean, {a['chamfer_max_mm']:.2f} mm at most ({a['chamfer_patches']} "
               f"patches; target under 1 mm: {'met' if a['chamfer_max_mm'] < 1 else 'not met'})"
               if a["chamfer_mm"] is not None else "not measured (no stored points)")
    lines = [FIGURES_START, f"## Figures: {provenance(r)}", "",
             f"{r['unique_codes']:,} unique codes from {r['grasps']:,} grasps on {r['objects']} objects "
             f"(`{r['objects_source']}`); the one object is {size} m, its {a['unique_codes']:,} patches are "
             f"{a['patch_pieces']:,} convex pieces clipped from the source objects' decompositions; fidelity "
             f"{a['fidelity']:.1%} (target 100%: {'met' if a['fidelity'] == 1 else 'not met'}), Chamfer distance to "
             f"the representatives' stored crops {chamfer}, corridor intrusions {a['corridor_intrusions']}.", "",
             f"Label cost: {a['label_trials_one_object']:,} label trials on the one object against "
             f"{a['label_trials_all_grasps']:,} for labelling every extracted grasp with the same protocol: {cost} "
             f"({r['grasps'] / max(r['unique_codes'], 1):.2f} grasps per unique code).", "",
             f"Storage: {r['bytes_per_extracted_grasp']:,} bytes per extracted grasp in `grasps/` (pose, candidate "
             f"pose, width, shift, codes, indices{points}); the whole dataset {r['bytes_on_disk'] / 1e6:.1f} MB."]
    if labels:
        lines += ["", f"Label stage: {labels['labelled_grasps']:,} of {labels['label_trials']:,} trials held after "
                  f"closing; {labels['success_rate']:.1%} of those succeed."]
    transfer = labels.get("transfer")
    if transfer:
        rows = [[name, m["pairs"], _or_dash(m["success_agreement"]), _or_dash(m["quality_correlation"])]
                for name, m in (
            ("(a) patch on the one object vs its representative on the source", transfer["patch_vs_source"]),
            ("(b) representative vs the other grasps of its code", transfer["same_code"]),
            ("(c) random pairs of different codes (floor)", transfer["random_pairs"]))]
        met = (transfer["patch_vs_source"]["success_agreement"] or 0) >= 0.95
        lines += ["", f"Label transfer on {transfer['codes']} codes with two or more grasps "
                  f"({transfer['grasps_labelled']} source grasps labelled on their own objects):", "",
                  *table(["pairs compared", "pairs", "success agreement", "quality correlation"], rows), "",
                  f"Target for (a): at least 95% agreement: {'met' if met else 'not met'}. A correlation is empty "
                  "when one side is constant (one trial per label gives a quality of 0 or 1). When (c) is close to "
                  "(b), labels barely discriminate and these pairs cannot show that the code decides the label."]
    lines += ["", "Stage wall times (s): " + ", ".join(f"{k} {v:.1f}" for k, v in r["timings"].items()), FIGURES_END]
    return "\n".join(lines)


def _or_dash(value) -> str:
    return "-" if value is None else str(value)


def render_assembly_page() -> str:
    from benchmarks.experiments.bench_cpu_independence import CPU_END, CPU_START, cpu_section

    text = render_block(PAGE, FIGURES_START, FIGURES_END, "default_job", default_job_figures)
    return render_block(PAGE, CPU_START, CPU_END, "cpu_independence", cpu_section, text=text)
