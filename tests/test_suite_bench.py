"""The suite's own benchmark (benchmarks/speed/bench_suite.py): its per-test rows and its page section."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TWO_TESTS = """
import time


def test_sleeps():
    time.sleep(0.3)


def test_spins():
    start = time.process_time()
    while time.process_time() - start < 1.0:
        pass
"""


@pytest.mark.skipif(not Path("/proc/stat").is_file(), reason="the busy CPU-seconds are Linux's /proc/stat")
def test_the_plugin_writes_each_tests_wall_and_the_cpu_it_kept_busy(tmp_path):
    (tmp_path / "pytest.ini").write_text("[pytest]\n")  # this folder's own root: none of the suite's options
    (tmp_path / "test_two.py").write_text(TWO_TESTS)
    rows = tmp_path / "rows.jsonl"
    plugins = ["-p", "no:cacheprovider", "-p", "no:dash", "-p", "no:dash.testing.plugin", "-p",
               "benchmarks.speed.suite_cpu"]
    ran = subprocess.run([sys.executable, "-m", "pytest", "-q", *plugins, f"--suite-cpu-out={rows}", "test_two.py"],
                         cwd=tmp_path, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
                         timeout=120)
    assert ran.returncode == 0, ran.stdout[-2000:]
    found = {row["test"]: row for row in map(json.loads, rows.read_text().splitlines())}
    assert set(found) == {"test_two.py::test_sleeps", "test_two.py::test_spins"}
    assert found["test_two.py::test_sleeps"]["wall"] >= 0.3
    assert found["test_two.py::test_spins"]["busy"] >= 0.9  # its own second of CPU, whatever else ran


def test_the_summary_and_the_floor_are_read_as_pytest_and_the_cores_say():
    from benchmarks.speed.bench_suite import floor_seconds, outcomes

    assert outcomes("....\n764 passed, 5 skipped, 33 deselected, 1 warning in 951.46s (0:15:51)\n") == {
        "passed": 764, "skipped": 5, "deselected": 33}
    assert floor_seconds([{"busy_seconds": 1200.0}, {"busy_seconds": 600.0}], 2) == 900.0
    assert floor_seconds([{"busy_seconds": None}, {"busy_seconds": 600.0}], 2) is None


def suite_result(wall: float, busy: tuple[float, float]) -> dict:
    tests = [[{"test": "tests/a.py::test_cluster", "wall": 60.0, "busy": busy[0] * 0.5},
              {"test": "tests/a.py::test_kill", "wall": 20.0, "busy": busy[0] * 0.1}],
             [{"test": "tests/b.py::test_study", "wall": 30.0, "busy": busy[1] * 0.3}]]
    return {"command": ".venv/bin/python -m benchmarks.speed.bench_suite", "date": "2026-12-06",
            "machine": "x86_64, 2 cores", "cores": 2, "target_seconds": 600,
            "suite": {"wall_seconds": wall, "busy_seconds": 1.8 * wall, "outcomes": {"passed": 3}},
            "groups": [{"name": "ray", "marker": "ray or cluster", "wall_seconds": busy[0] / 1.5,
                        "busy_seconds": busy[0], "tests": tests[0]},
                       {"name": "rest", "marker": "not ray and not cluster", "wall_seconds": busy[1],
                        "busy_seconds": busy[1], "tests": tests[1]}],
            "floor_seconds": (busy[0] + busy[1]) / 2}


def test_the_section_says_whether_the_suite_and_its_floor_meet_the_target():
    from benchmarks.pages.suite_section import suite_section

    slow = "\n".join(suite_section(suite_result(951.0, (1131.0, 609.0))))
    assert "3 passed in 951 s" in slow and "(600 s): **not met**" in slow
    assert "870 s against the target's 600 s (**not met**)" in slow and "must shrink by 540 CPU-seconds (31%)" in slow
    assert "took 1.09 times the floor" in slow
    costliest = [line for line in slow.splitlines() if line.startswith("| `tests/")]
    assert [line.split("`")[1] for line in costliest] == ["tests/a.py::test_cluster", "tests/b.py::test_study",
                                                          "tests/a.py::test_kill"]
    quick = "\n".join(suite_section(suite_result(540.0, (700.0, 300.0))))
    assert "(600 s): **met**" in quick and "within reach of scheduling alone" in quick
