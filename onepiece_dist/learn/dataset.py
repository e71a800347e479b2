"""A torch Dataset over a OnePiece-Dist Zarr dataset (format 2), for our trainer and external ones.

Importable with numpy, zarr and torch alone (no ray, pybullet, open3d or pydantic): ``pip install
onepiece-dist[reader]`` documents that set. Nothing is unpickled: the arrays are plain numbers.

Reading is per batch: :meth:`GraspDataset.__getitems__` (which torch's DataLoader calls with a whole batch of
indices) reads each needed array once, only the requested rows (``oindex`` on the sorted unique rows, which
decodes only the chunks that hold them), and returns the batch as tensors. :class:`ChunkBatchSampler` draws
batches from a few random chunks at a time, so a batch touches few chunks. The store is opened lazily in each
DataLoader worker (zarr handles are not shared across processes), so ``num_workers > 0`` works.
"""

from __future__ import annotations

import math
import os

import numpy as np
import torch
import zarr
from torch.utils.data import Dataset, Sampler

from onepiece_dist.errors import StoreError
from onepiece_dist.store.format import format_problem

INPUTS = ("points", "code", "quality")  # what a dataset may hold besides labels; labels are always read
MODEL_INPUTS = {"pointnet": ("points",), "voxel": ("code",)}
SMALL_ARRAY_BYTES = 64 * 2**20  # arrays up to this size are read whole once per process, then indexed in memory


CROPS = ("gripper", "pointnetgpd")


def pointnetgpd_crop(points: np.ndarray, width: np.ndarray, closing_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """Our gripper-frame points (..., m, 3) in PointNetGPD's training frame, and the (..., m) mask of those in its
    box, for grasp widths ``width`` (...,).

    PointNetGPD crops around the grasp centre in a frame whose rows are approach, binormal (the closing axis) and
    minor normal = binormal x approach: our (u, v, -t), a left-handed frame. Its box is |x| < w/4, |y| < w/2,
    |z| < w/4 for the grasp width w. We do not store where along u the contacts lie, so the centre is the closing
    region's (closing_depth / 2, 0, 0): x' = u - closing_depth / 2, y' = v, z' = -t. Our crops hold the closing
    region only (|t| < closing_height / 2), so for w > 2 closing_height the box's top and bottom are missing.
    """
    local = np.asarray(points, dtype=np.float64) * [1.0, 1.0, -1.0] - [closing_depth / 2, 0.0, 0.0]
    w = np.asarray(width, dtype=np.float64)[..., None, None]
    half = np.concatenate([w / 4, w / 2, w / 4], axis=-1)
    return local, np.all(np.abs(local) < half, axis=-1)


class GraspDataset(Dataset):
    """Items: ``label`` () float32 success and ``group`` () int64 (object or patch id, for splits), plus those
    of ``inputs``: ``points`` (P, 3) float32 gripper-frame points, ``code`` (a, b, c) float32 occupancy,
    ``quality`` () float32 robust quality.

    crop : "gripper" (our closing region in our frame) or "pointnetgpd": ``points`` in PointNetGPD's training
           frame and box (:func:`pointnetgpd_crop`), the points inside resampled with replacement to P (seeded
           by row, as PointNetGPD resamples to its input size), and ``inside`` () int64 how many were inside
           before resampling (PointNetGPD drops grasps with fewer than 50)

    group : "grasps" (every object's grasps) or "assembled/grasps" (the one object's labelled grasps)
    rows : indices of the rows to use (a split); default all
    inputs : which of "points", "code" and "quality" to read (default: all the dataset holds); e.g.
             ``("code",)`` for a voxel model reads no points at all
    memory_bytes : arrays up to this size are read whole on first use (per process), then indexed in memory;
                   larger ones are read per batch. Raise it where the arrays fit in memory and batches are drawn
                   uniformly at random (each such batch decodes about one chunk per row from the store)
    """

    def __init__(self, path: str | os.PathLike, group: str = "assembled/grasps", rows: np.ndarray | None = None,
                 inputs: tuple[str, ...] | None = None, memory_bytes: int = SMALL_ARRAY_BYTES, crop: str = "gripper",
                 labelled: bool = True):
        if crop not in CROPS:
            raise ValueError(f"crop={crop!r}: expected one of {CROPS}")
        self.path, self.group, self.memory_bytes, self.crop = str(path), group, memory_bytes, crop
        root = zarr.open_group(self.path, mode="r")
        attrs = root.attrs.asdict()
        problem = format_problem(attrs)
        if problem:
            raise StoreError(f"{self.path}: not a readable OnePiece dataset: {problem}")
        if labelled and f"{group}/success" not in root:
            raise StoreError(f"{self.path}: {group}/success is missing: the dataset has no labels there "
                             "(run the 'label' stage, or extract with sim.label: true)")
        present = tuple(name for name in INPUTS if f"{group}/{name}" in root)
        self.inputs = present if inputs is None else tuple(inputs)
        missing = sorted(set(self.inputs) - set(present))
        if missing:
            raise StoreError(f"{self.path}: {group} holds no {missing} (present: {list(present)})")
        if crop == "pointnetgpd" and ("points" not in self.inputs or f"{group}/width" not in root):
            raise StoreError(f"{self.path}: crop='pointnetgpd' needs {group}/points and {group}/width")
        self.grid_shape = tuple(attrs["grid_shape"])
        self.closing_depth = float(attrs["gripper"]["closing_depth"]) if crop == "pointnetgpd" else None
        self.labelled = labelled  # False: candidates to score, every label read as 0
        stored = ("success", *self.inputs) if labelled else self.inputs
        self.length = int(root[f"{group}/{stored[0]}"].shape[0])
        self.rows = np.arange(self.length) if rows is None else np.asarray(rows, dtype=np.int64)
        self.chunk_rows = min(int(root[f"{group}/{name}"].chunks[0]) for name in stored)
        self.groups = root[f"{group}/{'patch' if group.startswith('assembled') else 'object'}"][:].astype(np.int64)
        self._root, self._small = None, {}

    def __len__(self) -> int:
        return len(self.rows)

    def _arrays(self):
        if self._root is None:  # opened lazily: once per DataLoader worker process
            self._root = zarr.open_group(self.path, mode="r")
        return self._root

    def _read(self, name: str, rows: np.ndarray) -> np.ndarray:
        """Rows (sorted, unique) of ``group/name``: from memory for an array up to ``memory_bytes`` (read whole
        on first use in this process), else from the store."""
        if name in self._small:
            return self._small[name][rows]
        array = self._arrays()[f"{self.group}/{name}"]
        if array.nbytes <= self.memory_bytes:
            self._small[name] = array[...]
            return self._small[name][rows]
        return _rows(array, rows)

    def __getitem__(self, item: int) -> dict[str, torch.Tensor]:
        return {name: value[0] for name, value in self.__getitems__([item]).items()}

    def __getitems__(self, items) -> dict[str, torch.Tensor]:
        """The batch of positions ``items`` as tensors with a leading batch axis, in the order given: one read
        per array, of the requested rows only."""
        rows = self.rows[np.asarray(items, dtype=np.int64)]
        wanted, back = np.unique(rows, return_inverse=True)
        labels = self._read("success", wanted)[back] if self.labelled else np.zeros(len(rows))
        out = {"label": torch.from_numpy(labels.astype(np.float32)),
               "group": torch.from_numpy(self.groups[rows])}
        for name in ("points", "quality"):
            if name in self.inputs:
                out[name] = torch.from_numpy(self._read(name, wanted)[back].astype(np.float32))
        if self.crop == "pointnetgpd" and "points" in self.inputs:
            out["points"], out["inside"] = self._pointnetgpd(out["points"].numpy(), self._read("width", wanted)[back],
                                                             rows)
        if "code" in self.inputs:
            a, b, c = self.grid_shape
            packed = self._read("code", wanted)[back]
            bits = np.unpackbits(packed, axis=1, count=a * b * c, bitorder="big")
            out["code"] = torch.from_numpy(bits.reshape(len(rows), a, b, c).astype(np.float32))
        return out

    batch = __getitems__

    def _pointnetgpd(self, points: np.ndarray, width: np.ndarray, rows: np.ndarray):
        local, inside = pointnetgpd_crop(points, width, self.closing_depth)
        out = np.zeros(points.shape, dtype=np.float32)
        for k, row in enumerate(rows):
            found = np.flatnonzero(inside[k])
            if len(found):
                pick = np.random.default_rng(int(row)).choice(found, size=points.shape[1], replace=True)
                out[k] = local[k, pick]
        return torch.from_numpy(out), torch.from_numpy(inside.sum(axis=1).astype(np.int64))

    def labels(self) -> np.ndarray:
        """(n,) success labels of this dataset's rows."""
        return self._arrays()[f"{self.group}/success"][:][self.rows].astype(np.float64)

    def split_by_group(self, validation: float, seed: int) -> tuple[GraspDataset, GraspDataset]:
        """(train, validation) with whole objects (or patches) on one side: never split by grasp."""
        groups = np.unique(self.groups[self.rows])
        rng = np.random.default_rng(seed)
        held = rng.permutation(groups)[: max(1, int(round(validation * len(groups))))]
        return self.split_by_groups(tuple(int(g) for g in held))

    def split_by_groups(self, held: tuple[int, ...]) -> tuple[GraspDataset, GraspDataset]:
        """(train, validation): the rows of the objects (or patches) ``held`` are the validation split."""
        in_val = np.isin(self.groups[self.rows], np.asarray(held, dtype=np.int64))
        return self._subset(self.rows[~in_val]), self._subset(self.rows[in_val])

    def _subset(self, rows: np.ndarray) -> GraspDataset:
        subset = GraspDataset.__new__(GraspDataset)
        subset.__dict__.update({**self.__dict__, "rows": rows, "_root": None, "_small": {}})
        return subset


def _rows(array, rows: np.ndarray) -> np.ndarray:
    """``array[rows]`` for sorted unique ``rows``: one slice over their span when it is short (a sampler's batch:
    zarr reads a slice faster than a selection of the same chunks), else an orthogonal selection, which decodes
    only the chunks that hold them (a sparse split)."""
    if len(rows) == 0:
        return np.zeros((0, *array.shape[1:]), dtype=array.dtype)
    lo, hi = int(rows[0]), int(rows[-1]) + 1
    if hi - lo <= max(4 * len(rows), 2 * array.chunks[0]):
        block = array[lo:hi]
        return block if hi - lo == len(rows) else block[rows - lo]
    return array.oindex[(rows, *[slice(None)] * (array.ndim - 1))]


class ChunkBatchSampler(Sampler[list[int]]):
    """Batches of positions drawn from a few storage chunks at a time: chunks in random order, taken in groups of
    about two batches' worth of rows, whose positions are shuffled together and cut into batches, so a batch
    touches few chunks whatever its size. Use with ``DataLoader(ds, batch_sampler=..., collate_fn=collate)``."""

    def __init__(self, dataset: GraspDataset, batch_size: int, seed: int = 0):
        self.dataset, self.batch_size, self.seed, self.epoch = dataset, batch_size, seed, 0

    def __iter__(self):
        rng = np.random.default_rng([self.seed, self.epoch])
        self.epoch += 1
        chunk = self.dataset.rows // self.dataset.chunk_rows
        order = np.argsort(chunk, kind="stable")
        _, first_of, count = np.unique(chunk[order], return_index=True, return_counts=True)
        members = [order[a:a + n] for a, n in zip(first_of, count, strict=True)]  # positions of each chunk
        chunks = rng.permutation(len(members))
        per_group = max(1, math.ceil(2 * self.batch_size / self.dataset.chunk_rows))
        carry = np.zeros(0, dtype=np.int64)
        for start in range(0, len(chunks), per_group):
            taken = [members[k] for k in chunks[start:start + per_group]]
            positions = np.concatenate([carry, rng.permutation(np.concatenate(taken))])
            whole = len(positions) - len(positions) % self.batch_size
            for first in range(0, whole, self.batch_size):
                yield positions[first:first + self.batch_size].tolist()
            carry = positions[whole:]
        if len(carry):
            yield carry.tolist()

    def __len__(self) -> int:
        return math.ceil(len(self.dataset.rows) / self.batch_size)


def collate(items) -> dict[str, torch.Tensor]:
    """A batch from :meth:`GraspDataset.__getitems__` as it is, or a list of single items stacked."""
    if isinstance(items, dict):
        return items
    return {key: torch.stack([item[key] for item in items]) for key in items[0]}
