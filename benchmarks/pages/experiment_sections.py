"""The sections the paper-experiment page adds from later runs on its data (benchmarks/results): extraction
without physics (static crops), and what would lift B to R (B trained again, perfect patches, the label's
repeatability). Rendered into docs/performance.md by benchmarks/pages/report.py and docs/paper_experiment*.md."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.study.markdown import pct, provenance, table


def static_section(r: dict) -> list[str]:
    """Static crops against settled ones: extraction saved, shapes added, the projected time ratio."""
    rows = [[row["radius"], f"{row['shapes']:,}", f"{row['projected_core_seconds']:,.0f}",
             f"{row['projected_time_ratio']:.2f}x",
             *([f"{row['settled']['shapes']:,}", f"{row['settled']['core_seconds']:,.0f}",
                f"{row['settled']['time_ratio']:.2f}x"] if row["settled"] else ["-", "-", "-"])] for row in r["rows"]]
    return [f"## Extraction without physics (static crops): {provenance(r)}", "",
            f"The paper experiment's train objects ({r['objects']} x {r['candidates_per_object']} candidates), "
            f"cropped where each candidate was sampled: extraction {r['extraction_core_seconds']:,.0f} core-s for "
            f"{r['grasps']:,} grasps (every candidate kept), against {r['settled_extraction_core_seconds']:,.0f} "
            f"core-s for {r['settled_grasps']:,} settled grasps in the experiment (`{r['experiment']}`). Projected "
            f"cost of a B static arm = its extraction + shapes x {r['patch_seconds'] * 1000:.1f} ms (the "
            f"experiment's assemble + label cost per shape); time ratio = A's {r['a_core_seconds']:,.0f} core-s "
            "over it. Not labelled or trained: a projection from measured parts.", "",
            *table(["radius", "static shapes", "projected core-s", "projected time ratio", "settled shapes",
                    "settled core-s (measured)", "settled time ratio"], rows)]


VARIANT_WORDS = {"as_trained": "as the experiment trained it", "sqrt_weights": "weights: root of the code count",
                 "count_weights": "weights: code count", "representatives": "representatives' own crops",
                 "source_labels": "representatives' own crops and A's labels"}


def variants_section(r: dict, results: Path) -> list[str]:
    """B trained again with patch weights, its representatives' crops or their labels on the source objects,
    against the experiment's B and R; and how far the label protocol repeats itself."""
    def reaches_r(row: dict) -> bool:
        return row["ap"] >= row["experiment_r_ap"] and row["top1"] >= row["experiment_r_top1"]

    rows = [[row["radius"], VARIANT_WORDS[row["variant"]], f"{pct(row['top1'])} [{pct(row['top1_ci95'][0])}, "
             f"{pct(row['top1_ci95'][1])}]", f"{row['ap']:.3f} +- {row['ap_std']:.3f} [{row['ap_ci95'][0]:.3f}, "
             f"{row['ap_ci95'][1]:.3f}]", f"{row['experiment_b_ap']:.3f}", f"{row['experiment_r_ap']:.3f}",
             "yes" if reaches_r(row) else "no"] for row in r["rows"]]
    lifted = [row for row in r["rows"] if row["variant"] != "as_trained" and reaches_r(row)]
    return [f"## What would lift B to R: {provenance(r)}", "",
            f"The B arms of the paper experiment (`{r['experiment']}`, {r['experiment_date']}; "
            "docs/paper_experiment.md) trained again: with each patch's loss weighed by how many extracted grasps "
            "its label stands for (its code's count, as the train stage's `weight_by_count`, or that count's "
            "square root); with B's labels on its representatives' own crops (each code's representative grasp "
            "cropped on its source object) instead of the one object's; with those crops and the labels A gave the "
            "representative grasps on their source objects (B as it would be if every patch's trial gave its "
            "source's label: a perfect patch); and as the experiment trained it (a check of the rerun). Everything "
            f"else as the experiment trained B ({r['model']}, {r['steps']} steps, its seeds and chosen learning "
            "rates); held-out: the experiment's held-out set. A variant lifts B to R when its mean AP and top-1 "
            "reach R's (same radius, same label budget)." + _datasets_sentence(r), "",
            *table(["radius", "B trained on", "held-out top-1 [95% CI]", "AP (mean +- sd over seeds) [95% CI]",
                    "experiment's B AP", "experiment's R AP", "at least R"], rows), "",
            "Lifts B to R: " + (", ".join(f"r{row['radius']} {VARIANT_WORDS[row['variant']]}" for row in lifted) + "."
                                if lifted else "none of these, at any radius tried.")
            + f" A random choice per held-out object succeeds {pct(r['heldout_random_choice'])} of the time: a top-1 "
            "below it ranks the held-out grasps worse than chance. Weighing by count puts most of the loss on a "
            "few large clusters, each with the one label of its representative.", "", *_perfect_patch(r),
            *_repeatability(r), *key_study_link(results)]


def _datasets_sentence(r: dict) -> str:
    """Whether the datasets trained on are the experiment's own, from their counts (``dataset_counts``)."""
    counts = r.get("dataset_counts")
    if not counts:
        return ""
    if all(here == there for here, there in counts.values()):
        return " The datasets are the experiment's own (same counts)."
    listed = ", ".join(f"{name} {here:,} ({there:,})" for name, (here, there) in counts.items())
    return (f" The datasets were made again from the experiment's specs ({r['date']}, {r['machine']}), and their "
            f"counts of labelled grasps differ a little from the experiment's (here, and in brackets the experiment's: "
            f"{listed}): on another CPU a few grasps in 10,000 come out otherwise (docs/assembly.md). The first row "
            "of each radius is this B; the columns beside it give the experiment's B and R.")


def _perfect_patch(r: dict) -> list[str]:
    """What the labels and the crops each change, per radius with both variants, in words from the figures."""
    by = {(row["radius"], row["variant"]): row for row in r["rows"]}
    lines = []
    for radius in sorted({row["radius"] for row in r["rows"]}):
        trained, real, perfect = (by.get((radius, v)) for v in ("as_trained", "representatives", "source_labels"))
        if not (trained and real and perfect):
            continue
        verdict = ("reaches R: a one-object trial that gave each patch its source's label would close the gap"
                   if perfect["ap"] >= perfect["experiment_r_ap"] and perfect["top1"] >= perfect["experiment_r_top1"]
                   else "still trails R in mean AP or top-1: even its source's own label for each shape does not "
                        "reach what as many labels of random candidates give, so more faithful trials on the one "
                        "object alone would not lift B to R here")
        lines += [f"- r{radius}: real crops instead of the one object's move AP from {trained['ap']:.3f} to "
                  f"{real['ap']:.3f}; A's labels on them instead of B's, to {perfect['ap']:.3f} (top-1 "
                  f"{pct(perfect['top1'])}; R: AP {perfect['experiment_r_ap']:.3f}, top-1 "
                  f"{pct(perfect['experiment_r_top1'])}). B with perfect patches {verdict}."]
    return [*lines, ""] if lines else []


def _repeatability(r: dict) -> list[str]:
    rep, transfer = r.get("label_repeatability"), r.get("label_transfer") or {}
    if not rep:
        return []
    seen = "; ".join(f"r{k}: {pct(v['patch_vs_representative'])} with their representatives', "
                     f"{pct(v['patch_vs_every_grasp'])} with every grasp of their code" for k, v in transfer.items())
    return [f"**How far the label repeats itself.** {rep['grasps']:,} of A's grasps labelled again on their own "
            "objects with other perturbation draws (`--repeat-per-object`; the nominal trial is the same, the "
            f"perturbed ones are new) agree with A's labels {pct(rep['agreement'])} of the time (quality correlation "
            f"{rep['quality_correlation']}; positive rates {pct(rep['positive_rate'])} and "
            f"{pct(rep['positive_rate_again'])}, whose independent labellings would agree "
            f"{pct(rep['independent_floor'])}). No label of a grasp agrees with A's more often than A's own protocol "
            "does with itself: that is the ceiling of the label transfer, where B's patch labels agree "
            + (seen + " (docs/paper_experiment.md, Label transfer)." if seen else "as docs/paper_experiment.md "
               "shows (Label transfer).")]


def key_study_link(results: Path) -> list[str]:
    """A line naming the key study's pages (other dedup keys than the occupancy code) and what each says, where
    their results are committed in ``results``."""
    from benchmarks.pages.key_study_page import headline_sentence

    found = sorted(results.glob("key_study*.json"))
    if not found:
        return []
    said = [f"docs/{path.stem}.md: {headline_sentence(json.loads(path.read_text()))}" for path in found]
    return ["", "Other keys than the occupancy code, measured on unseen objects without a network "
            f"(the key study, measured with a script that is now the study option `keys`, docs/study.md): "
            f"{'; '.join(said)}."]
