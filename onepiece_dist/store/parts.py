"""Per-object result parts: one writer each, committed by an atomic directory rename.

A part lives at ``PARTS_DIR/<key>.zarr`` where ``key`` = object content id + job result key. It is written
into a private temporary folder (arrays first, its metadata attributes last), then the folder is renamed
into place: the rename is the commit marker, atomic on POSIX file systems. A reader sees a part only if
the final folder exists, so a crash never leaves a half-written part that looks complete; a second writer
of the same key (a retried task) finds it committed and discards its own copy, so writes are idempotent.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import time
import uuid
from pathlib import Path

import numpy as np
import zarr

from onepiece_dist.errors import StoreError
from onepiece_dist.store.codecs import write_array

_TMP = ".tmp-"
OWNER_FILE = "owner.json"  # in a temporary: who writes it (host, pid, process start), so others leave it alone
STALE_AFTER_S = 6 * 3600  # a temporary whose owner cannot be checked (another host, no owner file) expires then


class PartStore:
    """Folder of committed per-object parts."""

    def __init__(self, folder: str | os.PathLike):
        self.folder = Path(folder)

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.zarr"

    def is_committed(self, key: str) -> bool:
        return (self.path(key) / "zarr.json").is_file()

    def write(self, key: str, arrays: dict[str, np.ndarray], meta: dict) -> bool:
        """Write and commit a part. Returns False if the key was already committed (nothing changed)."""
        if self.is_committed(key):
            return False
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = self.folder / f"{_TMP}{key}-{uuid.uuid4().hex[:8]}"
        try:
            tmp.mkdir()
            (tmp / OWNER_FILE).write_text(json.dumps(this_process()))
            group = zarr.open_group(str(tmp), mode="a")
            for name, data in arrays.items():
                write_array(group, name, data)
            group.attrs.update({"key": key, **meta})
            (tmp / OWNER_FILE).unlink()
            return self._publish(tmp, key)
        except OSError as err:
            raise StoreError(f"cannot write part {key} in {self.folder}: {err.strerror or err}; "
                             "nothing of it was committed") from err
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)

    def _publish(self, tmp: Path, key: str) -> bool:
        try:
            os.rename(tmp, self.path(key))
            return True
        except OSError:
            if self.is_committed(key):
                return False  # a concurrent writer of the same deterministic content won
            raise

    def read_meta(self, key: str) -> dict:
        return dict(zarr.open_group(str(self.path(key)), mode="r").attrs)

    def read(self, key: str) -> dict[str, np.ndarray]:
        """All arrays of a committed part (KeyError if it is not committed)."""
        group = zarr.open_group(str(self._committed(key)), mode="r")
        return {name: array[...] for name, array in group.arrays()}

    def read_array(self, key: str, name: str) -> np.ndarray:
        """One array of a committed part, without opening the others (KeyError if not committed)."""
        return zarr.open_array(str(self._committed(key) / name), mode="r")[...]

    def array_shapes(self, key: str) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """Shape and dtype of every array of a committed part, from metadata only."""
        group = zarr.open_group(str(self._committed(key)), mode="r")
        return {name: (tuple(array.shape), np.dtype(array.dtype)) for name, array in group.arrays()}

    def _committed(self, key: str) -> Path:
        """The folder of a committed part (KeyError if it is not committed)."""
        if not self.is_committed(key):
            raise KeyError(f"part {key} is not committed in {self.folder}")
        return self.path(key)

    def committed_keys(self) -> list[str]:
        if not self.folder.is_dir():
            return []
        return sorted(p.name[:-5] for p in self.folder.glob("*.zarr") if (p / "zarr.json").is_file())

    def remove_stale_temporaries(self, now: float | None = None) -> int:
        """Delete temporaries whose writer is gone: its process on this host has ended, or (owner on another host,
        or unknown) it is older than STALE_AFTER_S. A temporary that a live writer, of this job or another job on
        the same cache, is still filling is left alone. Returns how many were removed."""
        now = time.time() if now is None else now
        stale = [path for path in (self.folder.glob(f"{_TMP}*") if self.folder.is_dir() else [])
                 if _abandoned(path, now)]
        for path in stale:
            shutil.rmtree(path, ignore_errors=True)
        return len(stale)


def this_process() -> dict:
    """The owner record of a temporary written by this process."""
    return {"host": socket.gethostname(), "pid": os.getpid(), "started": process_start(os.getpid())}


def process_start(pid: int) -> str:
    """When process ``pid`` started (clock ticks since boot, from /proc), or '' where that cannot be read: with the
    pid it names one process, even after the pid is reused."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return ""


def _abandoned(tmp: Path, now: float) -> bool:
    try:
        owner = json.loads((tmp / OWNER_FILE).read_text())
    except (OSError, ValueError):
        owner = None
    if owner is None or owner.get("host") != socket.gethostname():
        try:
            return now - tmp.stat().st_mtime > STALE_AFTER_S
        except OSError:
            return False
    return process_start(int(owner["pid"])) != owner.get("started")

