"""benchmarks/experiments/finite_set.py: the growth fits recover known curves, the committed page is the rendering of
the committed results, and --quick runs the whole measurement."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
finite = importlib.import_module("benchmarks.experiments.finite_set")


def rows(n: list[int], u: np.ndarray) -> list[dict]:
    return [{"objects": a, "unique_mean": float(b), "unique_min": int(b), "unique_max": int(b)}
            for a, b in zip(n, u, strict=True)]


def test_a_power_law_is_recovered_and_judged_better_than_a_saturation():
    n = [8, 16, 32, 64, 128, 256, 512]
    out = finite.fit(rows(n, 90 * np.array(n, dtype=float) ** 0.76))
    assert out["power_law"]["exponent"] == pytest.approx(0.76, abs=1e-6)
    assert out["power_law"]["largest_predicted_from_the_rest"] == pytest.approx(90 * 512**0.76, rel=1e-6)
    assert out["better_fit"] == "power law" and out["judged_by"].startswith("predicting")


def test_a_finite_set_is_judged_a_saturation():
    n = np.array([8, 16, 32, 64, 128, 256, 512], dtype=float)
    out = finite.fit(rows(n.astype(int).tolist(), 5000 * n / (40 + n)))
    assert out["better_fit"] == "saturation" and out["saturation"]["u_max"] == pytest.approx(5000, rel=1e-3)
    assert out["saturation"]["predicted"] < 5000 < out["power_law"]["predicted"]


def test_the_committed_page_is_the_rendering_of_the_committed_results(tmp_path):
    out = json.loads((ROOT / "benchmarks" / "results" / "finite_set.json").read_text())
    finite.write_page(out, tmp_path / "page.md")
    assert (tmp_path / "page.md").read_text() == (ROOT / "docs" / "finite_set.md").read_text()
    assert out["objects_ok"] >= 512 and out["grasps_per_object"] == 500
    assert {(c["resolution_mm"], c["radius"]) for c in out["curves"]} == {(10, 0), (10, 1), (10, 2), (5, 0), (20, 0)}


@pytest.mark.sim
@pytest.mark.slow
def test_the_quick_measurement_runs_end_to_end(tmp_path):
    out = finite.main(["--quick", "--in-process", "--folder", str(tmp_path / "work"), "--out", str(tmp_path)])
    assert out["objects_ok"] == 16 and (tmp_path / "docs" / "finite_set.md").is_file()
    exact = out["curves"][0]["rows"]
    assert [r["objects"] for r in exact] == [8, 16] and 0 < exact[0]["unique_mean"] <= exact[1]["unique_mean"]
