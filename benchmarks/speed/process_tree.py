"""A sampler of this process and its descendants (the driver, and every Ray process it started): resident memory
and CPU time, every ``period`` seconds with timestamps, so a stage's window can be cut out afterwards.

RSS counts shared pages once per process, so the memory sum is an upper bound. CPU time is user + system; a
process that exits keeps its CPU time at its last sample, so sums never drop.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import psutil


def process_kind(proc: psutil.Process, driver: int) -> str:
    """What a process of a job is: the driver, a Ray actor (by class), VHACD's child process, or the rest."""
    if proc.pid == driver:
        return "driver"
    title = " ".join(proc.cmdline())
    if title.startswith("ray::"):
        return title.split()[0].split(".")[0]
    if "vhacd" in title:
        return "VHACD child processes"
    return "Ray daemons and other processes"


class ProcessTree:
    """Samples (time, summed RSS, CPU seconds per kind of process) of the tree; ``kind(proc, driver_pid)`` names a
    process's kind (default: one kind, "all")."""

    def __init__(self, period: float = 0.2, kind: Callable[[psutil.Process, int], str] | None = None):
        self.period, self.kind, self.samples = period, kind or (lambda proc, driver: "all"), []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> ProcessTree:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        me, last = psutil.Process(), {}
        while not self._stop.is_set():
            rss = 0
            for proc in [me, *me.children(recursive=True)]:
                try:
                    rss += proc.memory_info().rss
                    times = proc.cpu_times()
                    last[proc.pid] = (self.kind(proc, me.pid), times.user + times.system)
                except psutil.Error:
                    pass
            cpu: dict[str, float] = {}
            for name, seconds in last.values():
                cpu[name] = cpu.get(name, 0.0) + seconds
            self.samples.append((time.perf_counter(), rss, cpu))
            self._stop.wait(self.period)

    def peak(self, since: float = 0.0, until: float = float("inf")) -> int:
        return max((rss for t, rss, _ in self.samples if since <= t <= until), default=0)

    def cpu_by_kind(self, since: float, until: float) -> dict[str, float]:
        """CPU seconds each kind spent between two times (the samples nearest them)."""
        inside = [cpu for t, _, cpu in self.samples if since <= t <= until]
        if len(inside) < 2:
            return {}
        return {name: seconds - inside[0].get(name, 0.0) for name, seconds in inside[-1].items()}

    def core_seconds(self, since: float, until: float) -> float:
        """CPU seconds the whole tree spent between two times."""
        return float(sum(self.cpu_by_kind(since, until).values()))
