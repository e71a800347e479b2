"""Storage per grasp: the same content written three ways in one run.

Run: .venv/bin/python benchmarks/bench_storage.py  (writes benchmarks/results/storage.json)
Content: the labelled grasps of a job on pybullet:named (codes, poses, labels, 750 gripper-frame points each).
Ways: our Zarr layout (blosc zstd, shuffled, 8192-row chunks; points float16); one .npy file of float32 points
per grasp plus one .npy per other array (the way PointNetGPD-style pipelines keep their clouds); one uncompressed
numpy archive (np.savez) of float32 arrays.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import tempfile
from datetime import date
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from onepiece_dist.service.local import run_local  # noqa: E402
from onepiece_dist.spec import JobSpec  # noqa: E402
from onepiece_dist.store import open_dataset  # noqa: E402
from onepiece_dist.store.dataset import disk_bytes  # noqa: E402

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
    total_zarr = sum(zarr_bytes.values())
    out = {"benchmark": "storage", "date": date.today().isoformat(), "machine": f"{platform.machine()}, "
           f"{os.cpu_count()} cores", "grasps": n,
           "bytes_per_grasp_zarr": {k: round(v / n, 1) for k, v in zarr_bytes.items()},
           "bytes_per_grasp": {"zarr": round(total_zarr / n, 1), "per_grasp_npy": round(npy_bytes / n, 1),
                               "uncompressed_npz": round(archive_bytes / n, 1)},
           "ratio_npy_over_zarr": round(npy_bytes / total_zarr, 2),
           "ratio_npz_over_zarr": round(archive_bytes / total_zarr, 2),
           "command": "python benchmarks/bench_storage.py"}
    (Path(__file__).parent / "results" / "storage.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


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
