"""The committed results (benchmarks/results/*.json) and the pieces every page renderer of benchmarks/ uses:
reading a result, "met"/"not met", and rendering one marked block of a page. The report and the page modules
import from here, not from each other."""

from __future__ import annotations

import json
from pathlib import Path
from string import Template

HERE = Path(__file__).resolve().parents[1]
RESULTS = HERE / "results"
TEMPLATES = Path(__file__).resolve().parent / "templates"  # the pages' prose, with $placeholders


def load(name: str) -> dict | None:
    """The committed result ``name`` (None when it was never run)."""
    path = RESULTS / f"{name}.json"
    return json.loads(path.read_text()) if path.is_file() else None


def met(value: float, target: float) -> str:
    return "met" if value >= target else "not met"


def render_block(page: Path, start_mark: str, end_mark: str, names: str | tuple[str, ...], section,
                 text: str | None = None) -> str:
    """``page``'s text (or ``text``, the page as rendered so far) with the block between the two marks rendered by
    ``section`` from the result(s) ``names`` (one argument each; the block is kept as it is when any of them is
    missing)."""
    text = page.read_text() if text is None else text
    results = [load(name) for name in ((names,) if isinstance(names, str) else names)]
    if any(result is None for result in results):
        return text
    start, end = text.index(start_mark), text.index(end_mark) + len(end_mark)
    return text[:start] + section(*results) + text[end:]


def fill(template: str, **values) -> str:
    """The page template ``templates/<template>.md`` with its ``$name`` placeholders replaced by ``values`` (every
    one must be given: a missing figure is an error, never a blank)."""
    return Template((TEMPLATES / f"{template}.md").read_text()).substitute(values)
