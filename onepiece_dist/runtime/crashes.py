"""Crash records: how the worker pool tells an item that crashes its worker from a worker killed from outside.

Each worker process points Python's ``faulthandler`` at a file of its own in the job's crash folder (inside the
parts folder, so shared by every node) and, before each item, rewrites the file's first line with the item it
starts (``"<method> <index>"``), and after it with ``idle``. A fatal signal raised in the process (a segfault in
the simulator, an abort, a bus error) makes ``faulthandler`` append "Fatal Python error" to that file before the
process dies. A SIGKILL (an operator, a chaos run, a node going away) leaves nothing. The pool counts the two
apart (a kill by Ray's memory monitor, reported as such, counts as the item's crash): an item is quarantined after
MAX_CRASHES crashes while it ran alone; deaths without a record are retried up to MAX_UNEXPLAINED times, a bound
for a job that something outside keeps killing, not a judgement on the item.
"""

from __future__ import annotations

import faulthandler
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

FATAL = "Fatal Python error"
IDLE = "idle"  # the record of a process between items


def crash_folder(parts_folder: str | os.PathLike, job_id: str) -> Path:
    """The job's crash folder: ``<parts folder>/.crashes/<job id>``."""
    return Path(parts_folder) / ".crashes" / job_id


class CrashLog:
    """This process's crash record file; keep the object alive as long as the process runs items."""

    def __init__(self, folder: str | os.PathLike):
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        self.file: IO[str] = open(folder / f"{socket.gethostname()}-{os.getpid()}.log", "w")  # noqa: SIM115
        faulthandler.enable(file=self.file, all_threads=False)

    def starting(self, method: str, index: int) -> None:
        """Record the item this process starts, before it starts."""
        self._record(f"{method} {index}")

    def finished(self) -> None:
        """Record that the item this process started has ended (the record then names no item: a process killed
        now was killed between items)."""
        self._record(IDLE)

    def _record(self, line: str) -> None:
        self.file.seek(0)
        self.file.truncate()
        self.file.write(f"{line}\n")
        self.file.flush()


@contextmanager
def running(log: CrashLog | None, method: str, index: int) -> Iterator[None]:
    """``log`` names item ``index`` of ``method`` while the block runs, and no item once it has ended (no log:
    nothing recorded)."""
    if log is not None:
        log.starting(method, index)
    yield
    if log is not None:
        log.finished()


def crashed_on(folder: str | os.PathLike, method: str, index: int) -> bool:
    """Whether a worker process left a crash record while running ``method`` on item ``index``; the record is
    consumed (removed), so each crash is counted once."""
    folder = Path(folder)
    found = False
    for path in folder.glob("*.log") if folder.is_dir() else []:
        try:
            text = path.read_text(errors="replace")
        except OSError:
            continue
        if text.startswith(f"{method} {index}\n") and FATAL in text:
            path.unlink(missing_ok=True)
            found = True
    return found
