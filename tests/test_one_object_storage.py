"""benchmarks/experiments/one_object_storage.py: the committed page is the rendering of the committed results, and those
results say what the issue asks (format 2 against format 1, delivered ratios against their targets)."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
storage = importlib.import_module("benchmarks.experiments.one_object_storage")


def test_the_committed_page_is_the_rendering_of_the_committed_results(tmp_path):
    out = json.loads((ROOT / "benchmarks" / "results" / "one_object_storage.json").read_text())
    storage.write_page(out, tmp_path / "page.md")
    assert (tmp_path / "page.md").read_text() == (ROOT / "docs" / "one_object_storage.md").read_text()
    assert not out["quick"] and [row["arm"] for row in out["arms"]] == ["B r0", "B r1", "B r2"]
    for row in out["arms"]:
        assert row["delivered_bytes"] < row["whole_bytes"] < row["format1_whole_bytes"]
        assert row["delivered_ratio"] == pytest.approx(out["a"]["delivered_bytes"] / row["delivered_bytes"], 1e-3)
    r2 = out["arms"][2]
    assert out["met"]["delivered_r2"] == (r2["delivered_ratio"] >= 6.3)
    page = (ROOT / "docs" / "one_object_storage.md").read_text()
    assert ("not met" in page) == (not all(out["met"].values()))
