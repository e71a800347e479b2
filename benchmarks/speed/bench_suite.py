"""The test suite's time against the guide's target (the README's test command within about 10 minutes here), and
where it goes: the suite run as the README runs it, then each of its two groups alone in one process, each test's
wall seconds and the machine's busy CPU-seconds (benchmarks/speed/suite_cpu.py).

    .venv/bin/python -m benchmarks.speed.bench_suite

About 40 minutes on 2 cores; run it on a quiet machine (the busy seconds are the machine's). The two groups are the
ones the suite schedules apart (tests/conftest.py): the tests that start Ray, one at a time on one worker, and the
rest beside them. The floor is every busy CPU-second of both groups over the cores: no order or number of workers
runs these tests faster on these cores. Results: benchmarks/results/suite.json, rendered into docs/performance.md
by benchmarks/pages/report.py.
"""

from __future__ import annotations

import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

from benchmarks.speed.suite_cpu import busy_seconds

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
TARGET_SECONDS = 600
GROUPS = (("ray", "ray or cluster"), ("rest", "not ray and not cluster"))
PYTEST = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]  # scripts/dev test: python -m pytest
OUTCOMES = ("passed", "failed", "skipped", "errors", "error", "deselected")


def outcomes(output: str) -> dict[str, int]:
    """{outcome: count} from pytest's last summary line ("764 passed, 5 skipped, 1 warning in 951.46s")."""
    lines = [line for line in output.splitlines() if re.search(r" in [\d.]+s", line)]
    found = re.findall(r"(\d+) (\w+)", lines[-1]) if lines else []
    return {name: int(count) for count, name in found if name in OUTCOMES}


def timed(args: list[str]) -> dict:
    """``args`` run from the checkout: its wall seconds, the machine's busy CPU-seconds meanwhile, its outcomes.
    Its user cache starts empty (a fresh ``XDG_CACHE_HOME``): the local jobs' decompositions (sim.collision) are
    made as on a fresh machine, not taken from an earlier run's."""
    with tempfile.TemporaryDirectory() as cache:
        busy, start = busy_seconds(), time.perf_counter()
        done = subprocess.run(args, cwd=ROOT, capture_output=True, text=True,
                              env={**os.environ, "XDG_CACHE_HOME": cache})
        wall, after = time.perf_counter() - start, busy_seconds()
    if done.returncode != 0:
        sys.exit(f"{' '.join(args[2:])} failed:\n{done.stdout[-3000:]}")
    return {"wall_seconds": round(wall, 1), "busy_seconds": None if busy is None else round(after - busy, 1),
            "outcomes": outcomes(done.stdout)}


def group(name: str, marker: str) -> dict:
    """The tests ``marker`` selects, alone in one process, with each test's row."""
    with tempfile.TemporaryDirectory() as folder:
        rows = Path(folder) / "rows.jsonl"
        measured = timed([*PYTEST, "-n", "0", "-m", marker, "-p", "benchmarks.speed.suite_cpu",
                          f"--suite-cpu-out={rows}"])
        tests = [json.loads(line) for line in rows.read_text().splitlines()]
    return {"name": name, "marker": marker, **measured, "tests": sorted(tests, key=lambda t: -(t["busy"] or 0))}


def floor_seconds(groups: list[dict], cores: int) -> float | None:
    """Every busy CPU-second of the groups run alone over ``cores``: the least wall time any schedule reaches."""
    busy = [g["busy_seconds"] for g in groups]
    return None if None in busy else round(sum(busy) / cores, 1)


def main() -> None:
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    suite = timed(PYTEST)
    groups = [group(name, marker) for name, marker in GROUPS]
    result = {"command": ".venv/bin/python -m benchmarks.speed.bench_suite", "date": date.today().isoformat(),
              "machine": f"{platform.machine()}, {cores} cores", "cores": cores, "target_seconds": TARGET_SECONDS,
              "user_cache": "empty at each run's start",
              "suite": suite, "groups": groups, "floor_seconds": floor_seconds(groups, cores)}
    out = HERE / "results" / "suite.json"
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(out)


if __name__ == "__main__":
    main()
