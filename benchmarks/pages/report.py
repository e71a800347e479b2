"""Every page in docs/ rendered from committed results, and how: one convention for all of them. A page is the text
a function makes from benchmarks/results/*.json (a page with prose around its figures: the text between its marks,
the rest kept), never typed; plots beside a page are drawn by the same module.

    python -m benchmarks.pages.report      # writes every page (scripts/dev bench runs it after the benchmarks)

tests/test_benchmark_report.py checks that each committed page is its rendering.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from benchmarks.pages import (
    assembly_page,
    committed,
    decomposition_page,
    experiment_page,
    finite_set_page,
    key_study_page,
    longer_page,
    one_object_storage_page,
    performance_page,
    picks_page,
    relabel_page,
    reliability_page,
    scaling_page,
    trials_page,
)
from benchmarks.pages.pick_curve_section import draw_curve
from onepiece_dist.study.pick_study import page as pick_page

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"
PICK_STUDY = "docs/studies/pick_labels"  # the study on pick labels (issue 58): its study.json, its page


@dataclass(frozen=True)
class Page:
    """A committed page (its path under the checkout) and the function that renders it from committed results."""

    path: str
    render: Callable[[], str]


def result(name: str) -> dict:
    return json.loads((RESULTS / f"{name}.json").read_text())


def pages() -> list[Page]:
    """Every rendered page, in the order they are written."""
    listed = [
        Page("docs/performance.md", performance_page.render),
        Page("docs/assembly.md", assembly_page.render_assembly_page),
        Page("docs/reliability.md", reliability_page.render_reliability_page),
        Page("docs/scaling.md", scaling_page.render_scaling_page),
        Page("docs/trials.md", trials_page.render_trials_page),
        Page("docs/picks.md", picks_page.render_picks_page),
        Page("docs/decomposition.md", lambda: decomposition_page.render(result("decomposition"),
                                                                        committed.load("worker_start"))),
        Page("docs/relabel.md", lambda: relabel_page.render(result("relabel_acronym"))),
        Page("docs/finite_set.md", lambda: finite_set_page.page_text(result("finite_set"))),
        Page("docs/one_object_storage.md", lambda: one_object_storage_page.page_text(result("one_object_storage"))),
    ]
    if (ROOT / PICK_STUDY / "study.json").is_file():
        listed.append(Page(f"{PICK_STUDY}/study.md",
                           lambda: pick_page.page_text(pick_page.read_result(ROOT / PICK_STUDY))))
    for name in ("paper_experiment", "paper_experiment_grasp_load"):
        listed.append(Page(f"docs/{name}.md", lambda name=name: experiment_page.page_text(result(name), RESULTS)))
    for path in sorted(RESULTS.glob("key_study*.json")):
        listed.append(Page(f"docs/{path.stem}.md", lambda stem=path.stem: key_study_page.page_text(result(stem))))
    for path in sorted(RESULTS.glob("paper_experiment*_longer*.json")):
        listed.append(Page(f"docs/{path.stem}.md", lambda stem=path.stem: longer_page.page(result(stem))))
    return listed


def write_page(path: str) -> None:
    """Write the listed page at ``path`` (under the checkout) from the committed results."""
    page = next(page for page in pages() if page.path == path)
    (ROOT / page.path).write_text(page.render())


def main() -> None:
    for page in pages():
        (ROOT / page.path).write_text(page.render())
        print(page.path)
    draw_curve(committed.load("pick_curve"), committed.load("picks"))


if __name__ == "__main__":
    main()
