"""Compressors and chunk shapes, chosen in one place."""

from __future__ import annotations

import numpy as np
from zarr.codecs import BloscCodec

GRASP_CHUNK_ROWS = 8192  # most rows in one chunk
CHUNK_BYTES = 4 * 2**20  # decoded bytes a chunk aims at: one random batch decodes few, small chunks


def shuffle_for(dtype: np.dtype) -> str:
    """Bit-shuffle for bytes (codes, bit-like); none for float16 (the point clouds: measured 10% smaller than
    byte-shuffle, benchmarks/speed/bench_storage.py); byte-shuffle for wider numbers."""
    dtype = np.dtype(dtype)
    if dtype.itemsize == 1:
        return "bitshuffle"
    return "noshuffle" if dtype == np.float16 else "shuffle"


def compressor_for(dtype: np.dtype) -> BloscCodec:
    """Blosc zstd level 5 (level 9 saves 0.5% more at 5x the write time; lz4 is 34% larger)."""
    return BloscCodec(cname="zstd", clevel=5, shuffle=shuffle_for(dtype), typesize=np.dtype(dtype).itemsize)


def chunks_for(shape: tuple[int, ...], rows: int = GRASP_CHUNK_ROWS, itemsize: int = 1) -> tuple[int, ...]:
    """Row chunks over the first axis, whole rows otherwise: at most ``rows`` rows, and fewer (a power of two, at
    least 64) where a row is large, so that a chunk holds about CHUNK_BYTES decoded (750-point float16 clouds:
    512 rows, 2.3 MB, instead of 8192 rows, 37 MB, for every random read)."""
    row_bytes = itemsize * int(np.prod(shape[1:], dtype=np.int64))
    fitting = 2 ** int(np.log2(max(1, CHUNK_BYTES // max(1, row_bytes))))
    return (max(1, min(rows, max(64, fitting), shape[0])), *shape[1:])


def write_array(group, name: str, data: np.ndarray, rows: int = GRASP_CHUNK_ROWS) -> None:
    """Create ``name`` in ``group`` holding ``data`` (compressed, row-chunked)."""
    data = np.ascontiguousarray(data)
    array = group.create_array(name, shape=data.shape, dtype=data.dtype,
                               chunks=chunks_for(data.shape, rows, data.dtype.itemsize),
                               compressors=[compressor_for(data.dtype)], overwrite=True)
    if data.size:
        array[...] = data
