"""Figures of the default job (the one `scripts/dev run` runs): the one object, its label cost and label transfer.

Run: .venv/bin/python -m benchmarks.experiments.default_job      (runs the default job on an embedded Ray, ~3 min)
     .venv/bin/python -m benchmarks.experiments.default_job --dataset onepiece-out/dataset.zarr
                                                                 (a dataset it already made)
Writes benchmarks/results/default_job.json; benchmarks/pages/report.py renders it into docs/assembly.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
from datetime import date
from pathlib import Path

from onepiece_dist.job.status import JobStatus
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import open_dataset
from onepiece_dist.store.dataset import disk_bytes

RESULTS = Path(__file__).resolve().parents[1] / "results"


def figures(dataset: Path) -> dict:
    ds = open_dataset(dataset)
    summary = ds.summary()
    status = JobStatus.load(dataset)
    grasp_bytes = disk_bytes(Path(dataset) / "grasps")
    return {"objects": summary["objects"], "grasps": summary["grasps"], "unique_codes": summary["unique_codes"],
            "bytes_on_disk": summary["bytes_on_disk"], "grasp_bytes": grasp_bytes,
            "bytes_per_extracted_grasp": round(grasp_bytes / max(summary["grasps"], 1), 1),
            "every_grasp_points": ds.has("grasps/points"), "assembly": ds.attrs["assembly"],
            "labels": ds.attrs.get("assembly_labels"), "timings": status.timings,
            "objects_source": ds.attrs["job_spec"]["objects"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", type=Path, default=None, help="a dataset of the default job already made")
    args = parser.parse_args()
    if args.dataset is None:
        from onepiece_dist.api import run_job

        folder = tempfile.mkdtemp(prefix="onepiece-default-")
        args.dataset = Path(folder) / "dataset.zarr"
        run_job(JobSpec(output=str(args.dataset)))
    spec = open_dataset(args.dataset).attrs["job_spec"]
    default = JobSpec().model_dump(mode="json", exclude={"output"})
    if {k: v for k, v in spec.items() if k != "output"} != default:
        raise SystemExit(f"{args.dataset}: not made by the default job spec")
    result = {"command": "python -m benchmarks.experiments.default_job", "date": str(date.today()),
              "machine": f"{platform.machine()}, {platform.python_version()}", **figures(args.dataset)}
    (RESULTS / "default_job.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
