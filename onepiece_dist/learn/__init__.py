"""Grasp networks (torch) and a reader of our Zarr layout for any training loop.

``from onepiece_dist.learn import GraspDataset`` needs only torch, zarr and numpy; the names load on first use, so
``onepiece_dist.learn.models`` imports with torch alone (a GPU machine without zarr trains with it).
"""

from __future__ import annotations

__all__ = ["ChunkBatchSampler", "GraspDataset"]


def __getattr__(name: str):
    if name in __all__:
        from onepiece_dist.learn import dataset

        return getattr(dataset, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
