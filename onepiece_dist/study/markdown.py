"""Markdown pieces the study's pages and the benchmark pages share (standard library only: the benchmark report
also runs on a GPU machine without the package's dependencies)."""

from __future__ import annotations


def table(header: list[str], rows: list[list]) -> list[str]:
    """A markdown table's lines."""
    return ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |",
            *["| " + " | ".join(str(c) for c in row) + " |" for row in rows]]


def provenance(result: dict) -> str:
    """'`command` (date, machine)' of a committed result."""
    return f"`{result['command'].strip()}` ({result['date']}, {result['machine']})"


def in_words(items: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return ", ".join(items[:-1]) + " and " + items[-1] if len(items) > 1 else items[0]


def pct(value: float | None) -> str:
    """A share as a percentage with one decimal ('-' for none)."""
    return "-" if value is None else f"{value:.1%}"


def pyplot():
    """matplotlib's pyplot without a display (the optional 'plots' extra)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
