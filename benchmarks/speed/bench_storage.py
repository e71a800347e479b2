"""Storage per grasp: the same content written three ways in one run.

Run: .venv/bin/python -m benchmarks.speed.bench_storage  (writes benchmarks/results/storage.json)
Content: the labelled grasps of a job on pybullet:named (codes, poses, labels, 750 gripper-frame points each).
Ways: our Zarr layout (blosc zstd, shuffled, 8192-row chunks; points float16); one .npy file of float32 points
per grasp plus one .npy per other array (the way PointNetGPD-style pipelines keep their clouds); one uncompressed
numpy archive (np.savez) of float32 arrays.
Then the compressor and chunk choice by measurement: the same arrays under each blosc setting and chunk height,
bytes per grasp and write/read time (the setting in store/codecs.py is marked).
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np

from onepiece_dist.runtime.local import run_local
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import disk_bytes

ARRAYS = ("code", "pose", "success", "quality", "points")


def main() -> dict:
    with tempfile.TemporaryDirectory() as folder:
        spec = JobSpec(objects=os.environ.get("BENCH_STORAGE_OBJECTS", "pybullet:named"), grasps_per_object=64,
                       output=f"{folder}/ds.zarr", stages=("ingest", "extract", "dedup"), sim={"label": True})
        run_local(spec)
        ds = open_dataset(spec.output)
        content = {name: ds[f"grasps/{name}"] for name in ARRAYS}
        n = len(content["code"])
        zarr_bytes = {name: disk_bytes(Path(spec.output) / "grasps" / name) for name in ARRAYS}
        npy_bytes = _per_grasp_npy(content, Path(folder) / "npy")
        archive = Path(folder) / "all.npz"
        np.savez(archive, **{k: v.astype(np.float32) if v.dtype.kind == "f" else v for k, v in content.items()})
        archive_bytes = archive.stat().st_size
        sweep = compressor_sweep(content, Path(folder) / "sweep")
    total_zarr = sum(zarr_bytes.values())
    out = {"benchmark": "storage", "date": date.today().isoformat(), "machine": f"{platform.machine()}, "
           f"{os.cpu_count()} cores", "grasps": n,
           "bytes_per_grasp_zarr": {k: round(v / n, 1) for k, v in zarr_bytes.items()},
           "bytes_per_grasp": {"zarr": round(total_zarr / n, 1), "per_grasp_npy": round(npy_bytes / n, 1),
                               "uncompressed_npz": round(archive_bytes / n, 1)},
           "ratio_npy_over_zarr": round(npy_bytes / total_zarr, 2),
           "ratio_npz_over_zarr": round(archive_bytes / total_zarr, 2),
           "compressor_sweep": sweep,
           "command": "python -m benchmarks.speed.bench_storage"}
    (Path(__file__).resolve().parents[1] / "results" / "storage.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


SETTINGS = [("zstd", 5, "auto"), ("zstd", 1, "auto"), ("zstd", 9, "auto"), ("zstd", 5, "shuffle"),
            ("zstd", 5, "bitshuffle"), ("zstd", 5, "noshuffle"), ("lz4", 5, "auto"), ("lz4hc", 9, "auto")]
CHUNK_ROWS = (256, 8192)


def compressor_sweep(content: dict[str, np.ndarray], folder: Path) -> list[dict]:
    """Bytes per grasp and seconds to write and read all arrays under each (codec, level, shuffle, chunk rows);
    'auto' shuffle = per dtype as store/codecs.py chooses (bit-shuffle bytes, none for float16, byte-shuffle
    wider numbers)."""
    import zarr
    from zarr.codecs import BloscCodec

    from onepiece_dist.store.codecs import GRASP_CHUNK_ROWS, shuffle_for

    rows, n = [], len(content["code"])
    for cname, level, shuffle in SETTINGS:
        for chunk in CHUNK_ROWS:
            path = folder / f"{cname}-{level}-{shuffle}-{chunk}.zarr"
            group = zarr.open_group(str(path), mode="w")
            start = time.perf_counter()
            for name, data in content.items():
                mode = shuffle if shuffle != "auto" else shuffle_for(data.dtype)
                codec = BloscCodec(cname=cname, clevel=level, shuffle=mode, typesize=data.dtype.itemsize)
                array = group.create_array(name, shape=data.shape, dtype=data.dtype,
                                           chunks=(min(chunk, len(data)), *data.shape[1:]), compressors=[codec])
                array[...] = data
            written = time.perf_counter() - start
            start = time.perf_counter()
            for name in content:
                zarr.open_array(str(path / name), mode="r")[...]
            rows.append({"codec": cname, "level": level, "shuffle": shuffle, "chunk_rows": chunk,
                         "bytes_per_grasp": round(disk_bytes(path) / n, 1), "write_s": round(written, 3),
                         "read_s": round(time.perf_counter() - start, 3),
                         "ours": (cname, level, shuffle) == ("zstd", 5, "auto") and chunk == GRASP_CHUNK_ROWS})
    return rows


def _per_grasp_npy(content: dict[str, np.ndarray], folder: Path) -> int:
    """Bytes on disk of one float32 .npy cloud per grasp plus one .npy per other array (4 KiB blocks counted as
    the file system stores them)."""
    folder.mkdir()
    for i, cloud in enumerate(content["points"]):
        np.save(folder / f"{i:07d}.npy", cloud.astype(np.float32))
    for name in ARRAYS[:-1]:
        np.save(folder / f"{name}.npy", content[name])
    return sum(os.stat(p).st_blocks * 512 for p in folder.iterdir())


if __name__ == "__main__":
    main()
