"""Compressors and chunk shapes, chosen in one place."""

from __future__ import annotations

import numpy as np
from zarr.codecs import BloscCodec

GRASP_CHUNK_ROWS = 8192


def compressor_for(dtype: np.dtype) -> BloscCodec:
    """zstd with bit-shuffle for bytes (codes, bit-like), byte-shuffle for wider numbers."""
    shuffle = "bitshuffle" if np.dtype(dtype).itemsize == 1 else "shuffle"
    return BloscCodec(cname="zstd", clevel=5, shuffle=shuffle, typesize=np.dtype(dtype).itemsize)


def chunks_for(shape: tuple[int, ...], rows: int = GRASP_CHUNK_ROWS) -> tuple[int, ...]:
    """Row chunks over the first axis, whole rows otherwise."""
    return (max(1, min(rows, shape[0])), *shape[1:])


def write_array(group, name: str, data: np.ndarray, rows: int = GRASP_CHUNK_ROWS) -> None:
    """Create ``name`` in ``group`` holding ``data`` (compressed, row-chunked)."""
    data = np.ascontiguousarray(data)
    array = group.create_array(name, shape=data.shape, dtype=data.dtype, chunks=chunks_for(data.shape, rows),
                               compressors=[compressor_for(data.dtype)], overwrite=True)
    if data.size:
        array[...] = data
