"""docs/key_study.md and its plot, rendered from benchmarks/results/key_study.json (written by the script
benchmarks/key_study.py, since replaced by the study option ``keys``: study/keys.py)."""

from __future__ import annotations

from pathlib import Path

from benchmarks.pages.committed import fill
from onepiece_dist.study.markdown import in_words, pct, pyplot

REFERENCE = "occupancy 10 mm"  # the code the paper experiment dedups by


def _reference(out: dict) -> dict:
    """The row of the experiment's own code."""
    return next(r for r in out["keys"] if r["key"] == REFERENCE)


def _num(x: float | None, digits: int = 3) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def key_table(out: dict) -> list[str]:
    lines = ["| key | bytes | unique fraction (train) | same-key / random-pair agreement (train) | held-out coverage "
             "| one train label: agreement (floor) | share decided | majority label: agreement (floor) "
             "| share decided |", "| --- |" + " --- |" * 8]
    for r in out["keys"]:
        pairs, look = r["pairs"], r["lookup"]
        lines.append(
            f"| {r['key']} | {r['key_bytes']} | {_num(r['unique_fraction'])} "
            f"| {pct(pairs['same_code']['success_agreement'])} / {pct(pairs['random_pairs']['success_agreement'])} "
            f"| {pct(look['coverage'])} | {pct(look['one_label']['agreement'])} ({pct(look['one_label']['floor'])}) "
            f"| {_num(r['decided_share_one_label'], 2)} | {pct(look['majority']['agreement'])} "
            f"({pct(look['majority']['floor'])}) | {_num(r['decided_share_majority'], 2)} |")
    return lines


def budget_table(out: dict) -> list[str]:
    lines = ["| key | labels (B = R = S) | A: AP, accuracy | B: AP +- sd, accuracy (coverage) | R: AP +- sd, "
             "accuracy (coverage) | S: AP +- sd, accuracy (coverage) | B at least R |", "| --- |" + " --- |" * 6]
    for r in out["keys"]:
        budget = r["budget"]
        lines.append(f"| {r['key']} | {budget['B']['labels']:,} | {_num(budget['A']['ap'])}, "
                     f"{pct(budget['A']['accuracy'])} | {_drawn(budget['B'])} | {_drawn(budget['R'])} "
                     f"| {_drawn(budget['S'])} | {'yes' if b_holds(r) else 'no'} |")
    return lines


def _drawn(arm: dict) -> str:
    return f"{_num(arm['ap'])} +- {_num(arm['sd']['ap'])}, {pct(arm['accuracy'])} ({pct(arm['coverage'])})"


def b_holds(row: dict) -> bool:
    """B's lookup at least as good as R's: its mean AP and mean accuracy both no lower than R's."""
    b, rand = row["budget"]["B"], row["budget"]["R"]
    return b["ap"] >= rand["ap"] and b["accuracy"] >= rand["accuracy"]


def budget_verdict(out: dict) -> str:
    holds = [r["key"] for r in out["keys"] if b_holds(r)]
    ref = _reference(out)["budget"]
    said = (f"for {in_words(holds)}" if holds else "for none of the keys tried")
    above = [r["key"] for r in out["keys"] if beyond_spreads(r["budget"]["S"], r["budget"]["R"])]
    below = sum(beyond_spreads(r["budget"]["R"], r["budget"]["B"]) for r in out["keys"])
    return (f"- **B against R, without a network:** one label per key ranks held-out grasps at least as well as "
            f"as many random labels {said} (the occupancy code: B AP {_num(ref['B']['ap'])} +- "
            f"{_num(ref['B']['sd']['ap'])} against R "
            f"{_num(ref['R']['ap'])} +- {_num(ref['R']['sd']['ap'])}, every label {_num(ref['A']['ap'])}); its AP "
            f"is below R's by more than both spreads for {below} of {len(out['keys'])} keys. The same "
            f"number of labels spread over the keys by the root of their counts (S) ranks above R beyond both "
            f"spreads for "
            f"{in_words(above) if above else 'none of the keys'} (the occupancy code: S AP {_num(ref['S']['ap'])} "
            f"+- {_num(ref['S']['sd']['ap'])}).")


def redundancy_table(out: dict) -> list[str]:
    lines = ["| key | grasps per object (first n) | train grasps | unique fraction | B: AP +- sd | R: AP +- sd "
             "| S: AP +- sd | R - B |", "| --- |" + " --- |" * 7]
    for r in out.get("redundancy", []):
        b = r["budget"]
        lines.append(f"| {r['key']} | {r['grasps_per_object']} | {r['grasps']:,} | {_num(r['unique_fraction'])} "
                     f"| {_num(b['B']['ap'])} +- {_num(b['B']['sd']['ap'])} "
                     f"| {_num(b['R']['ap'])} +- {_num(b['R']['sd']['ap'])} "
                     f"| {_num(b['S']['ap'])} +- {_num(b['S']['sd']['ap'])} | {_num(b['R']['ap'] - b['B']['ap'])} |")
    return lines


def redundancy_verdict(out: dict) -> str:
    """How R - B moves from the fewest to the most grasps per object, per key."""
    said = []
    for key in dict.fromkeys(r["key"] for r in out.get("redundancy", [])):
        rows = sorted((r for r in out["redundancy"] if r["key"] == key), key=lambda r: r["grasps_per_object"])
        gap = [r["budget"]["R"]["ap"] - r["budget"]["B"]["ap"] for r in rows]
        said.append(f"{key}: R - B {_num(gap[0])} at {rows[0]['grasps_per_object']} grasps per object (unique "
                    f"{_num(rows[0]['unique_fraction'])}), {_num(gap[-1])} at {rows[-1]['grasps_per_object']} "
                    f"(unique {_num(rows[-1]['unique_fraction'])})")
    return ("- **As redundancy grows:** " + "; ".join(said) + ".") if said else ""


def beyond_spreads(high: dict, low: dict) -> bool:
    """Mean AP of ``high`` above ``low``'s by more than their two spreads (sd over draws; 0 for one run) added."""
    spread = high.get("sd", {}).get("ap", 0.0) + low.get("sd", {}).get("ap", 0.0)
    return high["ap"] - low["ap"] > spread


def dominating(out: dict) -> list[dict]:
    """Keys that repeat at least as much as the reference code (unique fraction no higher) and decide more of the
    label on held-out objects (share decided by one train label higher), with coverage no lower."""
    ref = _reference(out)
    return [r for r in out["keys"] if r["key"] != REFERENCE and r["decided_share_one_label"] is not None
            and ref["decided_share_one_label"] is not None
            and r["unique_fraction"] <= ref["unique_fraction"]
            and r["lookup"]["coverage"] >= ref["lookup"]["coverage"]
            and r["decided_share_one_label"] > ref["decided_share_one_label"]]


def verdict(out: dict) -> list[str]:
    ref = _reference(out)
    better = dominating(out)
    most = max((r for r in out["keys"] if r["decided_share_one_label"] is not None),
               key=lambda r: r["decided_share_one_label"], default=None)
    lines = [f"- **The experiment's code ({REFERENCE}):** {_num(ref['unique_fraction'])} of the train grasps are "
             f"unique; a held-out grasp finds its code among the train grasps {pct(ref['lookup']['coverage'])} of "
             f"the time, and a train label of that code agrees with its own "
             f"{pct(ref['lookup']['one_label']['agreement'])} of the time against "
             f"{pct(ref['lookup']['one_label']['floor'])} "
             f"for a label that ignores the shape: a share of {_num(ref['decided_share_one_label'], 2)} of what a "
             f"label can agree beyond chance (the ceiling, A against itself: {pct(out['ceiling']['agreement'])})."]
    if better:
        names = ", ".join(f"{r['key']} (unique {_num(r['unique_fraction'])}, share "
                          f"{_num(r['decided_share_one_label'], 2)})" for r in better)
        lines.append(f"- **Keys that repeat at least as much and decide more:** {names}.")
    else:
        lines.append("- **Keys that repeat at least as much and decide more:** none of those tried.")
    lines.append(budget_verdict(out))
    if out.get("redundancy"):
        lines.append(redundancy_verdict(out))
    if most is not None:
        lines.append(f"- **Most decisive key tried:** {most['key']}: share {_num(most['decided_share_one_label'], 2)} "
                     f"at unique fraction {_num(most['unique_fraction'])} and held-out coverage "
                     f"{pct(most['lookup']['coverage'])}.")
    return lines


def headline_sentence(out: dict) -> str:
    """One sentence of what the study found, for the pages that link it."""
    ref = _reference(out)
    better = dominating(out)
    load = "a payload at the grasp centre" if out["load"] == "grasp" else "the object"
    verbs = "repeats as much and decides" if len(better) == 1 else "repeat as much and decide"
    found = (f"{in_words([r['key'] for r in better])} {verbs} more"
             if better else "no key tried repeats as much and decides more")
    holds = sum(b_holds(r) for r in out["keys"])
    return (f"lifting {load}, the occupancy code carries a share of {_num(ref['decided_share_one_label'], 2)} of the "
            f"decidable label at unique fraction {_num(ref['unique_fraction'])}; {found}; one label per key ranks "
            f"held-out grasps at least as well as as many random labels for {holds} of {len(out['keys'])} keys")


def page_text(out: dict) -> str:
    """The page (templates/key_study.md) with this result's figures."""
    train, held, ceiling = out["train"], out["heldout"], out["ceiling"]
    load = ("a payload of {:g} kg at the grasp centre".format(out["load_mass"]) if out["load"] == "grasp"
            else "the object itself")
    redundancy = _redundancy_section(out)
    return fill("key_study", command=out["command"], date=out["date"], machine=out["machine"],
                minutes=f"{out['wall_seconds'] / 60:.1f}", jobs=_jobs(out), name=out["name"],
                label_trials=out["label_trials"], load=load, train_objects=train["objects"],
                train_grasps=f"{train['grasps']:,}", train_rate=pct(train["positive_rate"]),
                heldout_objects=held["objects"], heldout_grasps=f"{held['grasps']:,}",
                heldout_rate=pct(held["positive_rate"]), mean_points=f"{train['mean_points']:g}",
                ceiling_grasps=f"{ceiling['grasps']:,}", ceiling_agreement=pct(ceiling["agreement"]),
                ceiling_floor=pct(ceiling["independent_floor"]), verdict="\n".join(verdict(out)),
                key_table="\n".join(key_table(out)), draws=out["keys"][0]["budget"]["R"]["draws"],
                budget_table="\n".join(budget_table(out)),
                redundancy="\n".join(redundancy) + "\n" if redundancy else "")


def write_page(out: dict, path: Path) -> None:
    path.write_text(page_text(out))


def _redundancy_section(out: dict) -> list[str]:
    if not out.get("redundancy"):
        return []
    return ["## As redundancy grows", "",
            "The same lookups with each train object cut to its first n labelled grasps (as if it had been given "
            "fewer candidates; the held-out grasps stay the same): more grasps per object repeat more keys, the "
            "regime where the method should pay.", "", *redundancy_table(out), ""]


def _jobs(out: dict) -> str:
    """The labelling jobs' own minutes (their stages' seconds), and whether this run reused them."""
    parts = [f"{name} {sum(job['stages'].values()) / 60:.1f} min" for name, job in out["jobs"].items()]
    reused = [name for name, job in out["jobs"].items() if job["reused"]]
    said = f", reused from an earlier run of the same spec: {in_words(reused)}" if reused else ""
    return f"; labelling jobs, one process each: {in_words(parts)}{said}"


def plot_keys(out: dict, path: Path) -> None:

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.0), dpi=110)
    for k, r in enumerate(out["keys"]):
        share, majority = r["decided_share_one_label"], r["decided_share_majority"]
        marker, colour = {"occupancy": "s", "contact": "o", "both": "^"}[r["kind"]], f"C{k}"
        if majority is not None:
            ax.scatter(r["unique_fraction"], majority, marker=marker, facecolors="none", edgecolors=colour,
                       label="the key's majority label" if k == 0 else None)
        if share is not None:
            ax.scatter(r["unique_fraction"], share, marker=marker, color=colour,
                       label="one train label of the key (B)" if k == 0 else None)
            ax.annotate(r["key"], (r["unique_fraction"], share), fontsize=6)
    ax.set_xlim(-0.03, 1.25)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_xlabel("unique fraction of train grasps (labels paid / grasps)")
    ax.set_ylabel("share of the label decided (held-out lookup)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
