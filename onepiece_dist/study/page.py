"""The study's page (``study.md``) and plot (``study.png``), rendered from a :class:`StudyResult` and nothing else:
the answer first, then the arms, the held-out set and the premise. Every figure is the result's."""

from __future__ import annotations

from pathlib import Path

from onepiece_dist.study.levels import levels_lines
from onepiece_dist.study.markdown import pct, pyplot
from onepiece_dist.study.result import Arm, Measure, StudyResult


def megabytes(count: int | None) -> str:
    return "-" if count is None else f"{count / 1e6:.2f} MB"


def measure(m: Measure, percent: bool) -> str:
    show = pct if percent else (lambda v: f"{v:.3f}")
    return f"{show(m.mean)} [{show(m.interval[0])}, {show(m.interval[1])}]"


def verdict(result: StudyResult) -> list[str]:
    """The first lines: the cheapest plan as good as A, its cost, and whether the one object pays."""
    d, a = result.decision, result.arms[0]
    conf = f"{100 * result.spec.targets.confidence:.0f}%"
    lines = [f"**Answer.** On these {result.train_objects} train objects and {result.heldout.objects} held-out "
             f"objects, {label_words(result)}, A (every candidate labelled) reaches held-out top-1 "
             f"{measure(a.heldout.top1, True)} and AP {measure(a.heldout.ap, False)} ({conf} intervals over held-out "
             "objects)."]
    lines += ceiling_lines(result)
    if d.cheapest is None or d.cheapest == "A":
        lines.append("No cheaper plan reaches A's intervals: **label everything (A)**.")
    else:
        t = result.spec.targets
        lines.append(f"The cheapest plan inside A's intervals is **{d.cheapest}**: {d.cheapest_core_seconds:.1f} "
                     f"core-seconds and {d.cheapest_label_trials:,} label trials ({d.cheapest_time_ratio:.1f}x less "
                     f"time than A; target {t.time_ratio:g}x: {'met' if d.time_met else 'not met'}), "
                     f"{megabytes(d.cheapest_labelled_bytes)} of labelled grasps ({d.cheapest_storage_ratio:.1f}x "
                     f"less; target {t.storage_ratio:g}x: {'met' if d.storage_met else 'not met'}).")
    if d.best_b is None:
        lines.append("No one-object arm (B) reaches A's intervals.")
    else:
        lines.append(f"The cheapest one-object arm inside A's intervals is {d.best_b}.")
    for name, beats in d.b_beats_random.items():
        lines.append(f"{name} {'beats' if beats else 'does not beat'} a random subset of its size "
                     f"(R ~{name}: {'both' if beats else 'not both'} top-1 and AP at least R's).")
    if d.u_beats_random is not None:
        u = next(arm for arm in result.arms if arm.name == "U")
        lines.append(f"The adaptive arm U ({u.cost.labelled_grasps:,} labels chosen by the network in "
                     f"{len(result.adaptive or [])} rounds) {'beats' if d.u_beats_random else 'does not beat'} as "
                     f"many random labels (R ~U: {'both' if d.u_beats_random else 'not both'} top-1 and AP at least "
                     "R's).")
        lines += adaptive_target_lines(result, u)
    for p in result.premise:
        lines.append(f"Premise at radius {p.radius}: a patch's label agrees with the grasps it stands for "
                     f"{pct(p.patch_vs_every_grasp)} (floor {pct(p.shuffled_patches)}); the code decides "
                     f"{pct(p.share_decided)} of the label's headroom over chance.")
    return lines


def picks_lines(result: StudyResult) -> list[str]:
    """The decision made on picks (spec.judge: picks or both), first."""
    p = result.picks
    if p is None:
        return []
    a = next(arm for arm in p.arms if arm.name == "A")
    guess = (f"a random candidate picks {measure(p.random, True)}"
             + ("" if p.separable else ": **the picks cannot separate a network from a guess** (below 10% or "
                "above 90%)"))
    cheapest = next(arm for arm in p.arms if arm.name == p.cheapest)
    by_how_much = ("" if p.cheapest == "A" else f", {pct(cheapest.first_attempt.mean)} against A's "
                   f"{pct(a.first_attempt.mean)} ({100 * (cheapest.first_attempt.mean - a.first_attempt.mean):+.0f} "
                   "points)")
    lines = [f"**Judged by picks.** From one depth view of each of {p.objects} held-out objects ({p.views} views "
             f"each; {p.label}), A's networks pick {measure(a.first_attempt, True)} at the first attempt; {guess}. "
             f"The cheapest plan inside A's interval by pick success is **{p.cheapest}**{by_how_much}."]
    said = {"beats": "beats", "ties": "ties with", "loses": "loses to"}
    lines += [f"By picks, {name} {said[p.b_versus_random[name]]} random labels of its size (R ~{name}; the 95% "
              "interval of their per-object difference)." if name in p.b_versus_random else
              f"By picks, {name} {'beats' if beats else 'does not beat'} random labels of its size (R ~{name})."
              for name, beats in p.b_beats_random.items()]
    return lines


def picks_table(result: StudyResult) -> list[str]:
    p = result.picks
    if p is None:
        return []
    held = {arm.name: arm for arm in result.arms}
    return ["## Judged by picks and by candidates", "",
            "Pick success: each seed's network plans on the camera's cloud and its first choice is executed by the "
            f"label protocol (the pick benchmark, docs/picks.md); candidates: held-out top-1 and AP among "
            f"{candidate_words(result.spec)}.", "",
            "| arm | pick success (first attempt) | inside A (picks) | held-out top-1 | held-out AP | inside A "
            "(candidates) |", "| --- | --- | --- | --- | --- | --- |",
            *(f"| {arm.name} | {measure(arm.first_attempt, True)} | {'yes' if arm.within_a else 'no'} | "
              f"{measure(held[arm.name].heldout.top1, True)} | {measure(held[arm.name].heldout.ap, False)} | "
              f"{'yes' if held[arm.name].within_a else 'no'} |" for arm in p.arms if arm.name in held), ""]


def ceiling_lines(result: StudyResult) -> list[str]:
    """Where A (and every arm) stands between the label's floor and its own ceiling (spec.ceiling_grasps), all on
    the same fresh executions of the sampled held-out candidates."""
    c = result.ceiling
    if c is None:
        return []
    way = lambda name: ("n/a" if c.share_of_way(c.arm_ap[name]) is None  # noqa: E731
                        else pct(c.share_of_way(c.arm_ap[name])))
    a = result.arms[0].name
    how = ("measured, below" if c.measured_ap is not None
           else "ranking by each grasp's odds, their spread fitted to the draws")
    return [f"The label's own ceiling ({c.grasps} held-out candidates, each executed {c.draws} times again with "
            f"fresh perturbations): two executions of one grasp agree {pct(c.agreement)}; against one execution the "
            f"floor (positive rate) is {c.positive_rate:.3f} and the best AP a predictor could reach "
            f"{c.ceiling:.3f} ({how}; the draws alone show at least {c.ceiling_ap:.3f}). On the same executions "
            f"A's networks reach AP {c.arm_ap[a]:.3f}: "
            f"**{way(a)} of the way from the floor to the ceiling**; "
            + ", ".join(f"{name} {way(name)}" for name in c.arm_ap if name != a) + "."] + single_lines(c, a) \
        + measured_lines(c)


def single_lines(c, a: str) -> list[str]:
    """Single networks apart from the seed ensembles the line above scores (issue 58)."""
    if not c.single_ap:
        return []
    return ["", f"These APs score each arm's seeds averaged (an ensemble). Its networks one at a time (the mean of "
            f"each seed's own AP): A {c.single_ap[a]:.3f} against {c.arm_ap[a]:.3f} for the ensemble; "
            + ", ".join(f"{name} {ap:.3f}" for name, ap in c.single_ap.items() if name != a) + "."]


def measured_lines(c) -> list[str]:
    """The measured ceiling (issue 58), where the study drew enough executions per grasp to measure it."""
    if c.measured_ap is None:
        return []
    low, high = c.measured_interval
    return ["", f"Measured from {c.draws} executions of each of the {c.grasps} grasps, the ceiling is "
            f"**{c.measured_ap:.3f} [{low:.3f}, {high:.3f}]** (the odds' distribution their counts make most likely; "
            "95% interval, grasps resampled): the arms above are placed against it. Two moments alone allow "
            f"{c.moment_range[0]:.3f} to {c.moment_range[1]:.3f} (two-point odds with the draws' mean and spread); "
            f"the moment fit says {c.fitted_ap:.3f}."]


def adaptive_target_lines(result: StudyResult, u) -> list[str]:
    """Issue 39's targets for U, met or not."""
    d, t = result.decision, result.spec.targets
    if d.u_met is None:
        return []
    fewer = d.r_labels_at_u_ap is None or d.r_labels_at_u_ap > u.cost.labelled_grasps
    reach = (f"random labels reach U's held-out AP ({u.heldout.ap.mean:.3f}) with {d.r_labels_at_u_ap:,} labels"
             if d.r_labels_at_u_ap is not None else f"no R arm reaches U's held-out AP ({u.heldout.ap.mean:.3f})")
    return [f"Target for U, inside A's intervals at no more than {t.adaptive_share:.0%} of A's core-seconds: "
            f"{'met' if d.u_met else 'not met'} (U is {'inside' if u.within_a else 'outside'} A's intervals at "
            f"{d.u_cost_share:.1%} of A's core-seconds). Target for U, fewer labels than random labels for the same "
            f"held-out AP: {'met' if fewer else 'not met'} ({reach}; U used {u.cost.labelled_grasps:,})."]


def trials_words(s) -> str:
    trials = f"{s.label_trials} label trials per grasp ({s.success}, lifting the {s.load})"
    return trials if s.label == "physics" else (f"train labels by force closure (fc_mu <= {s.good_mu:g}), held-out "
                                                f"labels by {trials}")


def candidate_words(s) -> str:
    """How the held-out candidates were made: as every job of the study makes its candidates."""
    if not s.views:
        return "candidates sampled on the full mesh"
    return ("candidates proposed on each held-out view's cloud, as the planner proposes them" if s.view_sampling ==
            "view" else "candidates sampled on the mesh, each cropped from its nearest view")


def crop_words(s) -> str:
    """Which crops the arms train on when they are what a camera gives ('' for the full surface)."""
    if not s.views:
        return ""
    how = ("candidates proposed on each view's cloud as the planner proposes them" if s.view_sampling == "view"
           else "candidates sampled on the mesh, cropped from the nearest view")
    return f" on single-view crops ({s.views} depth views per object; {how})"


def label_words(result: StudyResult) -> str:
    s = result.spec
    if s.label == "physics":
        return f"every arm trained{crop_words(s)} on the physics trials' label"
    return (f"every arm trained{crop_words(s)} on force closure (good when fc_mu <= {s.good_mu:g}) and judged by "
            "physics trials on the held-out objects")


def label_fit_lines(result: StudyResult) -> list[str]:
    f = result.label_fit
    if f is None:
        return []
    return ["## The label against the held-out truth", "",
            f"No network: the held-out candidates ({f.grasps:,}) scored by force closure and labelled by physics "
            f"trials. Good by force closure (fc_mu <= {f.good_mu:g}): {pct(f.closure_positive_rate)}; held in the "
            f"trials: {pct(f.physics_positive_rate)}; the two labels agree on {pct(f.agreement)}. Ranked by fc_mu, "
            f"the candidates reach AP {f.ap:.3f} for physics success (a random ranking: "
            f"{f.physics_positive_rate:.3f}); per object, a candidate among those with the lowest fc_mu succeeds "
            f"{pct(f.top1)} (a random candidate: {pct(result.heldout.random_choice)}).", ""]


def adaptive_lines(result: StudyResult) -> list[str]:
    if not result.adaptive:
        return []
    plan = result.spec.adaptive
    return ["## The adaptive arm", "",
            f"Round 0 takes {pct(plan.first)} of A's candidates, one per code; each later round {pct(plan.batch)} "
            "more, where the network trained on the labels so far is least sure, one per code while codes last; "
            f"U stops after {plan.patience} rounds without a validation AP gain above {plan.margin:g}, or after "
            f"{plan.rounds} rounds. Its labels are A's; the validation rows are part of them.", "",
            "| round | labels | validation AP |", "| ---: | ---: | ---: |",
            *(f"| {r.round} | {r.labels:,} | {r.validation_ap:.3f} |" for r in result.adaptive), ""]


def lookup_lines(result: StudyResult) -> list[str]:
    k = result.lookup
    if k is None:
        return []
    lines = ["## The code as a lookup (no network)", "",
             f"Each held-out candidate looks its code up among A's {k.train_codes:,} train codes: {pct(k.coverage)} "
             f"find theirs. One train label of the code (B's one label per code) agrees with the held-out label "
             f"{pct(k.one_label)} (labels that ignore the shape: {pct(k.one_label_floor)}); the code's majority "
             f"{pct(k.majority)} (floor {pct(k.majority_floor)}). Held-out candidates ranked by the lookup:", "",
             "| labels from | labels | coverage | AP | accuracy |", "| --- | ---: | ---: | ---: | ---: |"]
    words = {"A": "every train grasp (A)", "B": "one per code (B)", "R": "as many at random (R)",
             "S": "as many spread over codes by count (S)"}
    lines += [f"| {words.get(arm, arm)} | {r.labels:,} | {pct(r.coverage)} | {r.ap:.3f} | {pct(r.accuracy)} |"
              for arm, r in k.ranked.items()]
    return [*lines, ""]


def keys_lines(result: StudyResult) -> list[str]:
    """The other keys of spec.keys as lookups (study.keys), beside the job's own code."""
    if not result.keys:
        return []
    lines = ["## Other keys as lookups", "",
             "Every grasp's crop at its settled pose keyed again (study.keys); each held-out candidate looks its key "
             "up among A's train grasps. Agreement is with the held-out label, beside labels that ignore the shape "
             "(floor); AP ranks the held-out candidates by one label per key (B) or as many random labels (R).", "",
             "| key | bytes | unique among A | coverage | one label (floor) | majority (floor) | AP B | AP R |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for key in result.keys:
        k = key.lookup
        lines.append(f"| {key.name} | {key.key_bytes} | {pct(key.unique_fraction)} | {pct(k.coverage)} | "
                     f"{pct(k.one_label)} ({pct(k.one_label_floor)}) | {pct(k.majority)} ({pct(k.majority_floor)}) "
                     f"| {k.ranked['B'].ap:.3f} | {k.ranked['R'].ap:.3f} |")
    return [*lines, ""]


def arm_row(arm: Arm) -> str:
    c, h = arm.cost, arm.heldout
    return (f"| {arm.name} | {c.labelled_grasps:,} | {c.label_trials:,} | {c.core_seconds:.1f} | "
            f"{arm.time_ratio:.2f} | {megabytes(c.labelled_bytes)} | {arm.storage_ratio:.2f} | "
            f"{megabytes(c.delivered_bytes)} | {megabytes(c.dataset_bytes)} | {measure(h.top1, True)} | "
            f"{measure(h.ap, False)} | "
            f"{h.learning_rate:g} | {'yes' if arm.within_a else 'no'} |")


def render_page(result: StudyResult, plot: str | None = None) -> str:
    s, h = result.spec, result.heldout
    lines = [f"# Study {result.digest}", "", *picks_lines(result), *levels_lines(result), *verdict(result), ""]
    if plot:
        lines += [f"![held-out top-1 and AP against labelled grasps]({plot})", ""]
    lines += ["## Arms", "",
              "A labels every candidate on its own object; B r builds the one object at similar-shape radius r and "
              "labels only there; "
              + ("B static r does the same from crops at each candidate's pose, with no physics in extraction; "
                 if s.static_radii else "")
              + "R labels a random share of A's candidates (R ~B r: as many as B r labels; R ~U: as "
              "many as U); U takes the labels the network asks for (The adaptive arm, below). Every "
              f"arm trains the {s.training.model} network {s.training.steps} steps, {s.training.seeds} seeds, at the "
              "learning rate its own validation split picks. Core-seconds are summed inside the workers; R is "
              "charged A's cost per candidate. Delivered: what a trainer needs (the one object and its labels for B, "
              "the labelled grasps for A; docs/dataset_format.md).", "",
              "| arm | labelled grasps | label trials | core-s | time A/arm | labelled | storage A/arm | delivered | "
              "whole store | held-out top-1 | held-out AP | rate | within A |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- | ---: | --- |",
              *(arm_row(arm) for arm in result.arms), "",
              "## Held-out objects", "",
              f"{h.objects} objects, {h.grasps:,} candidates, every one labelled; positive rate "
              f"{pct(h.positive_rate)}; a random candidate per object succeeds {pct(h.random_choice)}, an oracle "
              f"{pct(h.oracle)}.", ""]
    lines += picks_table(result)
    if result.premise:
        lines += ["## The premise", "",
                  "B's one label per patch against A's labels of the same candidates on their own objects.", "",
                  "| radius | matched grasps | patch vs representative | patch vs every grasp | shuffled (floor) | "
                  "same code (A) | random pairs (A) | share decided |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
                  *(f"| {p.radius} | {p.matched_grasps:,} | {pct(p.patch_vs_representative)} | "
                    f"{pct(p.patch_vs_every_grasp)} | {pct(p.shuffled_patches)} | {pct(p.same_code)} | "
                    f"{pct(p.random_pairs)} | {pct(p.share_decided)} |" for p in result.premise), ""]
    lines += adaptive_lines(result) + lookup_lines(result) + keys_lines(result) + label_fit_lines(result)
    if result.rejected:
        lines += ["## Rejected objects", "", *(f"- {r}" for r in result.rejected), ""]
    lines += ["## Run", "",
              f"{result.date}, {result.machine}, onepiece-dist {result.package_version}: {result.wall_seconds:.0f} s "
              f"wall; reused jobs: {', '.join(result.reused_jobs) or 'none'}; reused training runs: "
              f"{result.reused_runs}. Train `{s.train}` x {s.grasps_per_object} candidates, held-out `{s.heldout}` "
              f"x {s.heldout_grasps}, {trials_words(s)}.",
              ""]
    return "\n".join(lines)


def plot_curves(result: StudyResult, path: Path) -> bool:
    """Held-out top-1 and AP against labelled grasps (R's learning curve, B's arms, A's band); False without
    matplotlib (the optional 'plots' extra)."""
    try:
        plt = pyplot()
    except ImportError:
        return False
    a = result.arms[0]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, name, label in ((axes[0], "top1", "held-out top-1"), (axes[1], "ap", "held-out AP")):
        band = getattr(a.heldout, name).interval
        ax.axhspan(band[0], band[1], color="0.85", label="A's interval")
        for kind, marker in (("R", "o"), ("B", "s")):
            arms = sorted((arm for arm in result.arms if arm.kind == kind), key=lambda arm: arm.cost.labelled_grasps)
            if not arms:
                continue
            x = [arm.cost.labelled_grasps for arm in arms]
            m = [getattr(arm.heldout, name) for arm in arms]
            ax.errorbar(x, [v.mean for v in m], yerr=[[v.mean - v.interval[0] for v in m],
                                                      [v.interval[1] - v.mean for v in m]],
                        fmt=marker + ("-" if kind == "R" else ""), capsize=3, label=kind)
        ax.plot([a.cost.labelled_grasps], [getattr(a.heldout, name).mean], "k*", markersize=10, label="A")
        if name == "ap" and result.ceiling is not None:
            ax.axhline(result.ceiling.ceiling, color="tab:red", ls="--", label="the label's ceiling")
            ax.axhline(result.ceiling.positive_rate, color="0.5", ls=":", label="floor (positive rate)")
        ax.set_xscale("log")
        ax.set_xlabel("labelled grasps")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True


def write_pages(result: StudyResult, folder: Path) -> list[Path]:
    """``study.md`` (and ``study.png`` where matplotlib is installed) in ``folder``."""
    written = []
    plotted = plot_curves(result, folder / "study.png")
    if plotted:
        written.append(folder / "study.png")
    (folder / "study.md").write_text(render_page(result, "study.png" if plotted else None))
    written.append(folder / "study.md")
    return written
