"""Grasp networks (torch) and a reader of our Zarr layout for any training loop.

``from onepiece_dist.learn import GraspDataset`` needs only torch, zarr and numpy.
"""

from onepiece_dist.learn.dataset import ChunkBatchSampler, GraspDataset

__all__ = ["ChunkBatchSampler", "GraspDataset"]
