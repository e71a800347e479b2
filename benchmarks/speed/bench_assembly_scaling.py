"""The assemble stage on 1 and 2 workers at the paper's size (issue 43, item 2).

    .venv/bin/python -m benchmarks.speed.bench_assembly_scaling [--folder DIR] [--quick]

The B r0 job of examples/studies/paper.yaml (64 objects x 2,000 candidates, 11,678 patches) runs to its assemble
stage on the embedded Ray with 1 worker, then 2, then 1 and 2 again (the machine's drift shows in the repeats);
its extraction parts are shared (made once), its patch shards are removed before every run, so each run cuts
every patch again. Measured: the assemble stage's wall seconds (the workers cut the patches, the central actor
lays them out, checks and commits) and the patches' core-seconds. Target: speed-up >= 1.7x at 2 workers.

Writes benchmarks/results/assembly_scaling.json (the page: docs/performance.md, Assembly on the worker pool).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TARGET = 1.7


def run_once(spec, workers: int) -> dict:
    from onepiece_dist.api import run_job

    for part in Path(spec.parts_folder()).glob("patch-*"):
        shutil.rmtree(part)
    shutil.rmtree(spec.output, ignore_errors=True)
    status = run_job(spec, workers=workers)
    return {"workers": workers, "assemble_seconds": round(status.timings["assemble"], 2),
            "patches": status.progress.unique_codes}


def main(argv: list[str] | None = None) -> dict:
    from onepiece_dist.study.jobs import study_jobs
    from onepiece_dist.study.spec import load_study_spec

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=None, help="work folder, kept (extraction parts reused)")
    parser.add_argument("--quick", action="store_true", help="4 objects x 40 candidates: a smoke test")
    args = parser.parse_args(argv)
    overrides = {"train": "pybullet:random_urdfs[0:4]", "grasps_per_object": 40} if args.quick else {}
    study = load_study_spec(ROOT / "examples" / "studies" / "paper.yaml", overrides)
    folder = args.folder or Path(tempfile.mkdtemp(prefix="onepiece-asm-"))
    job = study_jobs(study, folder).b[0]
    spec = job.model_copy(update={"output": str(folder / "scaling.zarr"), "stages": ("ingest", "extract", "dedup",
                                                                                      "assemble")})
    runs = [run_once(spec, workers) for workers in (1, 2, 1, 2)]
    one = [r["assemble_seconds"] for r in runs if r["workers"] == 1]
    two = [r["assemble_seconds"] for r in runs if r["workers"] == 2]
    speedup = round((sum(one) / len(one)) / (sum(two) / len(two)), 3)
    out = {"benchmark": "assembly_scaling", "date": date.today().isoformat(), "quick": args.quick,
           "machine": f"{platform.machine()}, {os.cpu_count()} cores",
           "command": "python -m benchmarks.speed.bench_assembly_scaling" + (" --quick" if args.quick else ""),
           "spec": "examples/studies/paper.yaml, B r0", "patches": runs[0]["patches"], "runs": runs,
           "speedup_2_workers": speedup, "target": TARGET, "met": speedup >= TARGET}
    if not args.quick:
        (ROOT / "benchmarks" / "results" / "assembly_scaling.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
