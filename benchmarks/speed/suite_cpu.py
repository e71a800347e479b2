"""pytest plugin of benchmarks/speed/bench_suite.py (``-p benchmarks.speed.suite_cpu --suite-cpu-out PATH``): one
JSON line a test with its wall seconds and the machine's busy CPU-seconds while it ran (setup, call and teardown).

The busy seconds are every process's (Linux's /proc/stat): Ray's daemons and actors and the children a test starts
count, which no per-process clock sees. They are the test's own where it runs alone (``-n 0``) on a quiet machine;
under xdist two tests share them. Where /proc/stat is missing the busy seconds are None.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

STAT = Path("/proc/stat")
IDLE_FIELDS = (3, 4)  # idle and iowait, of the "cpu" line's user nice system idle iowait irq softirq steal ...


def busy_seconds() -> float | None:
    """CPU-seconds every core has spent busy since boot (None where the kernel does not say)."""
    if not STAT.is_file():
        return None
    ticks = [int(v) for v in STAT.read_text().splitlines()[0].split()[1:9]]
    return sum(t for k, t in enumerate(ticks) if k not in IDLE_FIELDS) / os.sysconf("SC_CLK_TCK")


def pytest_addoption(parser):
    parser.addoption("--suite-cpu-out", help="the JSON-lines file this plugin appends each test's row to")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    out = item.config.getoption("--suite-cpu-out")
    busy, start = busy_seconds(), time.perf_counter()
    yield
    if out:
        after = busy_seconds()
        row = {"test": item.nodeid, "wall": round(time.perf_counter() - start, 2),
               "busy": None if busy is None or after is None else round(after - busy, 2)}
        with open(out, "a") as rows:
            rows.write(json.dumps(row) + "\n")
