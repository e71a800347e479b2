"""The figures of docs/reliability.md: the chaos run's table (benchmarks/results/chaos.json) and the last column of
the guarantees table (the figures the reliability tests recorded, benchmarks/results/reliability.json), rendered by
benchmarks/pages/report.py (never typed)."""

from __future__ import annotations

import re
from pathlib import Path

from benchmarks.pages.committed import load, met, render_block
from onepiece_dist.study.markdown import provenance, table

PAGE = Path(__file__).resolve().parents[2] / "docs" / "reliability.md"
CHAOS_START = "<!-- chaos: rendered by benchmarks/pages/report.py from benchmarks/results/chaos.json -->"
CHAOS_END = "<!-- end of chaos -->"


def chaos_section(r: dict) -> str:
    rows = [[j["job"], j["state"], j["retries"], "yes" if j["identical"] else "no", j["lost_grasps"],
             j["duplicated_grasps"]] for j in r["jobs"]]
    lost, dup = r["lost_grasps"], r["duplicated_grasps"]
    nodes = sum(kill.startswith("worker node") for kill in r["kills"])
    workers = len(r["kills"]) - nodes
    return "\n".join([CHAOS_START, f"## Chaos run: {provenance(r)}", "",
                      f"{len(r['jobs'])} jobs at once on the local multi-node cluster (head + 2 worker nodes), "
                      f"{workers} simulation worker processes and {nodes} worker node{'s' * (nodes != 1)} (its raylet; "
                      "a replacement node joins) killed at seeded random times; each dataset compared with its "
                      "fault-free run (content digest).", "",
                      *table(["job", "state", "re-runs", "identical", "grasps lost", "grasps duplicated"], rows), "",
                      f"Recovered jobs: {r['recoveries']}. Grasps lost: {lost} (target 0: {met(-lost, 0)}); grasps "
                      f"duplicated: {dup} (target 0: {met(-dup, 0)}).", CHAOS_END])


GUARANTEES_START = ("<!-- guarantees: last column rendered by benchmarks/pages/report.py from "
                    "benchmarks/results/reliability.json -->")
GUARANTEES_END = "<!-- end of guarantees -->"
TEST_ID = re.compile(r"`((?:[\w/]+\.py)?)::(\w+)`")


def test_ids(cell: str) -> list[str]:
    """The test ids a table cell names (`` `file.py::test` ``, or `` `::test` `` for the file named before)."""
    ids, last = [], ""
    for file, test in TEST_ID.findall(cell):
        last = file or last
        ids.append(f"{last}::{test}")
    return ids


def figures_cell(cell: str, figures: dict) -> str:
    found = [f"{figures[t]['figure']} ({figures[t]['date']})" for t in test_ids(cell) if t in figures]
    return "; ".join(found) or "not recorded"


def guarantees_section(r: dict, page_text: str) -> str:
    """The guarantee table with each row's last cell rendered from the figures its tests recorded."""
    start, end = page_text.index(GUARANTEES_START), page_text.index(GUARANTEES_END)
    lines = page_text[start:end].splitlines()[1:]
    rows = [line for line in lines if line.startswith("| ")]
    out = [GUARANTEES_START, rows[0], rows[1]]
    for row in rows[2:]:
        cells = [c.strip() for c in row.strip("|").split(" | ")]
        out.append("| " + " | ".join([*cells[:3], figures_cell(cells[2], r["figures"])]) + " |")
    return "\n".join([*out, GUARANTEES_END])


def render_reliability_page() -> str:
    text = render_block(PAGE, CHAOS_START, CHAOS_END, "chaos", chaos_section)
    figures = load("reliability") or {"figures": {}}  # no recorded figures: every row says "not recorded"
    start, end = text.index(GUARANTEES_START), text.index(GUARANTEES_END) + len(GUARANTEES_END)
    return text[:start] + guarantees_section(figures, text) + text[end:]
