"""The dataset: a Zarr v3 group in format v2 (schemas/dataset_layout.json, docs/dataset_format.md).

Only one committer writes it. Root attribute ``complete`` is written last: a reader refuses a dataset
without it, so a crash mid-commit never looks like a finished dataset.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zarr

from onepiece_dist.errors import StoreError
from onepiece_dist.store.codecs import GRASP_CHUNK_ROWS, chunks_for, compressor_for, write_array
from onepiece_dist.store.format import FORMAT_VERSION, format_problem

NAME_BYTES = 64


@dataclass(frozen=True)
class ObjectTable:
    """Accepted objects, in job order. ids (n, 16) uint8 content-id digests; names (n, 64) uint8 UTF-8."""

    names: list[str]
    content_ids: list[str]
    grasp_counts: np.ndarray

    def arrays(self) -> dict[str, np.ndarray]:
        counts = np.asarray(self.grasp_counts, dtype=np.int64)
        return {
            "id": np.array([np.frombuffer(bytes.fromhex(c), np.uint8) for c in self.content_ids],
                           dtype=np.uint8).reshape(-1, 16),
            "name": encode_names(self.names),
            "grasp_start": (np.cumsum(counts) - counts).astype(np.int64),
            "grasp_count": counts,
        }


def encode_names(names: list[str]) -> np.ndarray:
    """(n, 64) uint8, UTF-8 truncated and zero-padded."""
    out = np.zeros((len(names), NAME_BYTES), dtype=np.uint8)
    for i, name in enumerate(names):
        raw = name.encode("utf-8")[:NAME_BYTES]
        out[i, :len(raw)] = np.frombuffer(raw, np.uint8)
    return out


def decode_names(rows: np.ndarray) -> list[str]:
    return [bytes(row).rstrip(b"\0").decode("utf-8", errors="replace") for row in rows]


def write_dataset(path: str | os.PathLike, attrs: dict, objects: ObjectTable,
                  groups: dict[str, dict[str, np.ndarray]]) -> None:
    """Write the global arrays and attributes, then mark the dataset complete.

    groups : {"grasps": {...}, "unique": {...}, ...} arrays by group; written under the root
    """
    begin_dataset(path, attrs)
    finish_dataset(path, objects, groups)


def begin_dataset(path: str | os.PathLike, attrs: dict) -> None:
    """Root attributes with ``complete = false``: what a commit writes first."""
    root = zarr.open_group(str(path), mode="a")
    root.attrs.update({**attrs, "onepiece_format": FORMAT_VERSION, "complete": False})


def finish_dataset(path: str | os.PathLike, objects: ObjectTable, groups: dict[str, dict[str, np.ndarray]]) -> None:
    """The remaining groups, consolidated metadata, then ``complete = true`` last."""
    write_groups(path, {"objects": objects.arrays(), **groups}, {"complete": True})


class GroupAppender:
    """Rows appended to the arrays of one group whose final lengths are known, written in whole chunks, so a
    commit holds one chunk per array in memory, not the whole corpus. One writer.

    layout : {name: (total_rows, row_shape, dtype)}
    """

    def __init__(self, path: str | os.PathLike, group_name: str, layout: dict[str, tuple[int, tuple, np.dtype]],
                 chunk_rows: int = GRASP_CHUNK_ROWS):
        group = zarr.open_group(str(path), mode="a").require_group(group_name)
        self.arrays, self.buffers, self.written = {}, {}, {}
        for name, (total, row_shape, dtype) in layout.items():
            shape = (total, *row_shape)
            self.arrays[name] = group.create_array(name, shape=shape, dtype=dtype,
                                                   chunks=chunks_for(shape, chunk_rows, np.dtype(dtype).itemsize),
                                                   compressors=[compressor_for(dtype)], overwrite=True)
            self.buffers[name], self.written[name] = [], 0

    def append(self, rows: dict[str, np.ndarray]) -> None:
        for name, data in rows.items():
            self.buffers[name].append(np.asarray(data, dtype=self.arrays[name].dtype))
            if sum(len(b) for b in self.buffers[name]) >= self.arrays[name].chunks[0]:
                self._flush(name, whole_chunks_only=True)

    def close(self) -> None:
        for name, array in self.arrays.items():
            self._flush(name, whole_chunks_only=False)
            if self.written[name] != array.shape[0]:
                raise StoreError(f"{array.path}: {self.written[name]} rows appended, {array.shape[0]} expected")

    def _flush(self, name: str, whole_chunks_only: bool) -> None:
        if not self.buffers[name]:
            return
        block = np.concatenate(self.buffers[name])
        step = self.arrays[name].chunks[0]
        count = len(block) - len(block) % step if whole_chunks_only else len(block)
        if count:
            start = self.written[name]
            self.arrays[name][start:start + count] = block[:count]
            self.written[name] += count
        self.buffers[name] = [block[count:]] if count < len(block) else []


def write_group(path: str | os.PathLike, group_name: str, arrays: dict[str, np.ndarray], attrs: dict) -> None:
    """Add a group of arrays to a complete dataset, then its root attributes ``attrs`` (written last: a reader
    that finds them finds the arrays too). Only the committer calls this."""
    write_groups(path, {group_name: arrays}, attrs)


def write_groups(path: str | os.PathLike, groups: dict[str, dict[str, np.ndarray]], last_attrs: dict) -> None:
    """Groups of arrays (name -> arrays) first, then consolidated metadata once, then ``last_attrs`` (the
    commit). Only the committer calls this."""
    root = zarr.open_group(str(path), mode="a")
    for group_name, arrays in groups.items():
        group = root.require_group(group_name)
        for name, data in arrays.items():
            write_array(group, name, data)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Consolidated metadata", UserWarning)
        zarr.consolidate_metadata(str(path))
    zarr.open_group(str(path), mode="a").attrs.update(last_attrs)


def update_attributes(path: str | os.PathLike, attrs: dict) -> None:
    """Set root attributes of a complete dataset (the committer only)."""
    zarr.open_group(str(path), mode="a").attrs.update(attrs)


class DatasetReader:
    """Read access to a complete dataset. Arrays load lazily through :meth:`array`."""

    def __init__(self, path: str | os.PathLike, allow_incomplete: bool = False):
        self.path = Path(path)
        if not (self.path / "zarr.json").is_file():
            raise StoreError(f"{self.path}: not a Zarr dataset (no zarr.json)")
        self.root = zarr.open_group(str(self.path), mode="r")
        attrs = dict(self.root.attrs)
        problem = format_problem({**attrs, "complete": True} if allow_incomplete else attrs)
        if problem:
            raise StoreError(f"{self.path}: {problem}")
        self.attrs = attrs

    def array(self, name: str) -> zarr.Array:
        try:
            return self.root[name]
        except KeyError:
            raise StoreError(f"{self.path}: no array {name!r}") from None

    def has(self, name: str) -> bool:
        try:
            self.root[name]
        except KeyError:
            return False
        return True

    def __getitem__(self, name: str) -> np.ndarray:
        return self.array(name)[...]

    @property
    def object_names(self) -> list[str]:
        return decode_names(self["objects/name"])

    def summary(self) -> dict:
        """Counts and sizes for `onepiece inspect`."""
        grasps = int(self.array("grasps/code").shape[0]) if self.has("grasps/code") else 0  # 0: a delivered copy
        unique = int(self.array("unique/code").shape[0]) if self.has("unique/code") else 0
        out = {
            "path": str(self.path),
            "objects": int(self.array("objects/name").shape[0]),
            "rejected": len(self.attrs.get("rejected", [])),
            "grasps": grasps,
            "unique_codes": unique,
            "unique_fraction": unique / grasps if grasps else 0.0,
            "grid_shape": self.attrs.get("grid_shape"),
            "bytes_on_disk": disk_bytes(self.path),
            "delivered_bytes": delivered_bytes(self.path),
        }
        for key in ("assembly", "assembly_labels", "budget_labels", "adaptive", "training", "evaluation"):
            if key in self.attrs:
                out[key] = self.attrs[key]
        if self.has("grasps/success") and grasps:
            out["success_rate"] = float(np.mean(self["grasps/success"])) if grasps else 0.0
        return out


EXTRACTION_RECORDS = ("grasps", "unique", "exact")  # every extracted candidate: what made the one object


def delivered_groups(path: str | os.PathLike) -> list[str]:
    """The top-level groups a trainer needs, the rest being records of how the dataset was made that a copy may
    leave out: with labels on the one object (assembled/grasps) or a budget's (labelled/grasps), everything but
    the extraction records (grasps/, unique/, exact/); with every candidate labelled (grasps/success), everything
    but unique/ and exact/; never adaptive/ (the rounds' record).
    The objects' meshes are references (objects/ names them) in both."""
    root = zarr.open_group(str(path), mode="r")
    apart = "assembled/grasps/success" in root or "labelled/grasps/success" in root  # labels beside the records
    drop = set(EXTRACTION_RECORDS) if apart else set(EXTRACTION_RECORDS) - {"grasps"}
    drop.add("adaptive")  # adaptive labelling's rounds: how the labels were chosen, scores of grasps/ rows
    return sorted(name for name, _ in root.groups() if name not in drop)


def delivered_bytes(path: str | os.PathLike) -> int:
    """Bytes on disk of the delivered dataset (:func:`delivered_groups`, with the root's metadata)."""
    path = Path(path)
    groups = sum(disk_bytes(path / name) for name in delivered_groups(path))
    return groups + sum(f.stat().st_size for f in path.iterdir() if f.is_file())


def copy_delivered(path: str | os.PathLike, out: str | os.PathLike) -> Path:
    """A copy of the dataset at ``path`` at ``out`` (a new folder) holding only its delivered groups (the
    extraction records left out), its root attributes and metadata consolidated again: a dataset every reader of
    the labelled grasps and of the one object opens as the original."""
    import shutil

    source, target = Path(path), Path(out)
    if target.exists():
        raise StoreError(f"{target}: already exists (give a new folder for the delivered dataset)")
    DatasetReader(source)  # a complete dataset of this format, or a clear error
    target.mkdir(parents=True)
    for entry in source.iterdir():
        if entry.is_file():
            shutil.copy2(entry, target / entry.name)
    for name in delivered_groups(source):
        shutil.copytree(source / name, target / name)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Consolidated metadata", UserWarning)
        zarr.consolidate_metadata(str(target))
    return target


def open_dataset(path: str | os.PathLike) -> DatasetReader:
    """Open a complete dataset for reading."""
    return DatasetReader(path)


def disk_bytes(path: Path) -> int:
    """Bytes of the files under ``path``."""
    return sum(os.path.getsize(os.path.join(top, f)) for top, _, files in os.walk(path) for f in files)


PLACE_KEYS = ("seconds", "output", "cache_dir", "decompositions", "checkpoint", "package_version")


def content_digest(path: str | os.PathLike, training: bool = True) -> str:
    """blake2b-128 hex of every array (path, dtype, shape, bytes, in path order) and of the root attributes that
    describe content, so two datasets with the same digest hold the same data. Left out: timings, the package
    version and where things were written (output, cache and checkpoint paths), so a job and its rerun elsewhere
    compare equal. ``training=False`` also leaves out ``train/`` and the ``training`` attribute: float sums in
    training depend on the thread count, so a trainer on one core and one on two differ in the last bits."""
    import hashlib
    import json

    root = zarr.open_group(str(path), mode="r")
    digest = hashlib.blake2b(digest_size=16)
    _digest_group(digest, "", root, skip=() if training else ("train",))
    attrs = {k: v for k, v in root.attrs.asdict().items() if training or k != "training"}
    digest.update(json.dumps(_content_only(attrs), sort_keys=True).encode())
    return digest.hexdigest()


def _digest_group(digest, prefix: str, group, skip: tuple[str, ...] = ()) -> None:
    for name, array in sorted(group.arrays(), key=lambda item: item[0]):
        digest.update(f"{prefix}{name}:{array.dtype}:{array.shape}".encode())
        digest.update(np.ascontiguousarray(array[...]).tobytes())
    for name, sub in sorted(group.groups(), key=lambda item: item[0]):
        if f"{prefix}{name}" not in skip:
            _digest_group(digest, f"{prefix}{name}/", sub)


def _content_only(value):
    """``value`` without the mapping entries that say when or where, not what: durations (``seconds``,
    ``*_seconds``, ``*_s``) and paths (``output``, ``cache_dir``, ``decompositions``, ``checkpoint``)."""
    if isinstance(value, dict):
        return {k: _content_only(v) for k, v in value.items()
                if not (k in PLACE_KEYS or k.endswith("_seconds") or k.endswith("_s"))}
    if isinstance(value, list):
        return [_content_only(v) for v in value]
    return value
