"""A torch Dataset over a OnePiece-Dist Zarr dataset (format 1), for our trainer and external ones.

The store is opened lazily in each DataLoader worker (zarr handles are not shared across processes), and
:class:`ChunkBatchSampler` draws batches chunk by chunk in random order, so random access does not decode a
whole chunk per item. Nothing is unpickled: the arrays are plain numbers.
"""

from __future__ import annotations

import os

import numpy as np
import torch
import zarr
from torch.utils.data import Dataset, Sampler

from onepiece_dist.errors import StoreError
from onepiece_dist.store.format import format_problem


class GraspDataset(Dataset):
    """Items: ``points`` (P, 3) float32 gripper-frame points, ``label`` () float32 success, ``quality`` ()
    float32, ``code`` (a, b, c) float32 occupancy, ``group`` () int64 (object or patch id, for splits).

    group : "grasps" (every object's grasps) or "assembled/grasps" (the one object's labelled grasps)
    rows : indices of the rows to use (a split); default all
    """

    def __init__(self, path: str | os.PathLike, group: str = "assembled/grasps", rows: np.ndarray | None = None):
        self.path, self.group = str(path), group
        root = zarr.open_group(self.path, mode="r")
        attrs = root.attrs.asdict()
        problem = format_problem(attrs)
        if problem:
            raise StoreError(f"{self.path}: not a readable OnePiece dataset: {problem}")
        if f"{group}/success" not in root:
            raise StoreError(f"{self.path}: {group}/success is missing: the dataset has no labels there "
                             "(run the 'label' stage, or extract with sim.label: true)")
        self.grid_shape = tuple(attrs["grid_shape"])
        self.length = int(root[f"{group}/success"].shape[0])
        self.rows = np.arange(self.length) if rows is None else np.asarray(rows, dtype=np.int64)
        self.chunk_rows = int(root[f"{group}/points"].chunks[0])
        self.groups = root[f"{group}/{'patch' if group.startswith('assembled') else 'object'}"][:].astype(np.int64)
        self._root = None

    def __len__(self) -> int:
        return len(self.rows)

    def _arrays(self):
        if self._root is None:  # opened lazily: once per DataLoader worker process
            self._root = zarr.open_group(self.path, mode="r")
        return self._root

    def __getitem__(self, item: int) -> dict[str, torch.Tensor]:
        return self.batch(np.array([item]))[0]

    def batch(self, items: np.ndarray) -> list[dict[str, torch.Tensor]]:
        """Items by position in this dataset, read with one slice per array (rows sorted)."""
        rows = self.rows[np.asarray(items)]
        order = np.argsort(rows)
        lo, hi = int(rows[order[0]]), int(rows[order[-1]]) + 1
        root, g = self._arrays(), self.group
        block = {name: root[f"{g}/{name}"][lo:hi] for name in ("points", "success", "quality", "code")}
        a, b, c = self.grid_shape
        out = []
        for row in rows:
            k = row - lo
            occupancy = np.unpackbits(block["code"][k], count=a * b * c, bitorder="big").reshape(a, b, c)
            out.append({"points": torch.from_numpy(block["points"][k].astype(np.float32)),
                        "label": torch.tensor(float(block["success"][k])),
                        "quality": torch.tensor(float(block["quality"][k])),
                        "code": torch.from_numpy(occupancy.astype(np.float32)),
                        "group": torch.tensor(int(self.groups[row]))})
        return out

    def labels(self) -> np.ndarray:
        """(n,) success labels of this dataset's rows."""
        return self._arrays()[f"{self.group}/success"][:][self.rows].astype(np.float64)

    def split_by_group(self, validation: float, seed: int) -> tuple[GraspDataset, GraspDataset]:
        """(train, validation) with whole objects (or patches) on one side: never split by grasp."""
        groups = np.unique(self.groups[self.rows])
        rng = np.random.default_rng(seed)
        held = set(rng.permutation(groups)[: max(1, int(round(validation * len(groups))))].tolist())
        in_val = np.isin(self.groups[self.rows], list(held))
        return self._subset(self.rows[~in_val]), self._subset(self.rows[in_val])

    def _subset(self, rows: np.ndarray) -> GraspDataset:
        subset = GraspDataset.__new__(GraspDataset)
        subset.__dict__.update({**self.__dict__, "rows": rows, "_root": None})
        return subset


class ChunkBatchSampler(Sampler[list[int]]):
    """Batches of positions that stay inside one storage chunk where possible: chunks in random order, items
    shuffled within each chunk. Use with ``DataLoader(ds, batch_sampler=..., collate_fn=collate)``."""

    def __init__(self, dataset: GraspDataset, batch_size: int, seed: int = 0):
        self.dataset, self.batch_size, self.seed, self.epoch = dataset, batch_size, seed, 0

    def __iter__(self):
        rng = np.random.default_rng([self.seed, self.epoch])
        self.epoch += 1
        chunk = self.dataset.rows // self.dataset.chunk_rows
        for c in rng.permutation(np.unique(chunk)):
            positions = rng.permutation(np.flatnonzero(chunk == c))
            for start in range(0, len(positions), self.batch_size):
                yield positions[start:start + self.batch_size].tolist()

    def __len__(self) -> int:
        chunk = self.dataset.rows // self.dataset.chunk_rows
        return int(sum(-(-np.sum(chunk == c) // self.batch_size) for c in np.unique(chunk)))


def collate(items: list[dict[str, torch.Tensor]]) -> dict[str, torch.Tensor]:
    return {key: torch.stack([item[key] for item in items]) for key in items[0]}
