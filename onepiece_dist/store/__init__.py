"""Zarr storage (format v2): per-object parts written by one writer each and committed atomically, and the
global dataset arrays written by one committer. Zarr details live only here."""

from onepiece_dist.store.dataset import FORMAT_VERSION, DatasetReader, open_dataset, write_dataset
from onepiece_dist.store.parts import PartStore

__all__ = ["FORMAT_VERSION", "DatasetReader", "PartStore", "open_dataset", "write_dataset"]
