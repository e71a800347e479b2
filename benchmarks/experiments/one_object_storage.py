"""What the one object costs on disk at the paper's size, in format 2 (issue 43, item 4).

    .venv/bin/python -m benchmarks.experiments.one_object_storage [--folder DIR] [--quick]

Runs the B jobs of examples/studies/paper.yaml (64 objects x 2,000 candidates; extraction once, then dedup,
assembly and labels on the one object at radius 0, 1 and 2) on the embedded Ray and measures each dataset: the
whole store, the delivered dataset (the one object and its labelled grasps, without the extraction records
grasps/ and unique/: store.dataset.delivered_groups) and every group. A's dataset does not change with format 2
(it has no one object): its bytes are the paper experiment's (benchmarks/results/paper_experiment.json, labelled
grasps = grasps/), its objects/ table the B jobs' own (the same objects). The format-1 figures beside them are the
experiment's too. Targets: delivered A/B >= 6.3x at B r2 (the paper's 43.7 GB / 6.9 GB) and >= 2x at B r0; B r0's
whole store no larger than A's.

Writes benchmarks/results/one_object_storage.json and docs/one_object_storage.md (``--render``: the page from it).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from datetime import date
from pathlib import Path

from benchmarks.pages.one_object_storage_page import write_page

ROOT = Path(__file__).resolve().parents[2]
TARGETS = {"delivered_r2": 6.3, "delivered_r0": 2.0}


def group_bytes(path: Path) -> dict[str, int]:
    from onepiece_dist.store.dataset import disk_bytes

    groups = {p.name: disk_bytes(p) for p in sorted(path.iterdir()) if p.is_dir()}
    assembled = path / "assembled"
    if assembled.is_dir():
        groups.update({f"assembled/{p.name}": disk_bytes(p) for p in sorted(assembled.iterdir()) if p.is_dir()})
    return groups


def measure(args, folder: Path) -> dict:
    from onepiece_dist.api import run_job
    from onepiece_dist.store.dataset import delivered_bytes, disk_bytes
    from onepiece_dist.study.jobs import finished, study_jobs
    from onepiece_dist.study.spec import load_study_spec

    overrides = {"train": "pybullet:random_urdfs[0:4]", "grasps_per_object": 40} if args.quick else {}
    spec = load_study_spec(ROOT / "examples" / "studies" / "paper.yaml", overrides)
    jobs = study_jobs(spec, folder)
    rows = []
    for radius, job in jobs.b.items():
        start = time.perf_counter()
        status = finished(job) or run_job(job, in_process=args.in_process)
        path = Path(job.output)
        rows.append({"arm": f"B r{radius}", "wall_seconds": round(time.perf_counter() - start, 1),
                     "assemble_seconds": round(status.timings.get("assemble", 0.0), 1),
                     "patches": status.progress.unique_codes, "whole_bytes": disk_bytes(path),
                     "delivered_bytes": delivered_bytes(path), "groups": group_bytes(path)})
    experiment = json.loads((ROOT / "benchmarks" / "results" / "paper_experiment.json").read_text())
    arms = {arm["arm"]: arm for arm in experiment["arms"]}
    objects = rows[0]["groups"].get("objects", 0)
    a = {"whole_bytes": arms["A"]["dataset_bytes"], "labelled_bytes": arms["A"]["labelled_bytes"],
         "delivered_bytes": arms["A"]["labelled_bytes"] + objects}
    for row in rows:
        before = arms.get(row["arm"], {})
        row["format1_whole_bytes"] = before.get("dataset_bytes")
        row["delivered_ratio"] = round(a["delivered_bytes"] / max(row["delivered_bytes"], 1), 3)
        row["whole_ratio"] = round(a["whole_bytes"] / max(row["whole_bytes"], 1), 3)
        row["format1_whole_ratio"] = round(a["whole_bytes"] / before["dataset_bytes"], 3) if before else None
    by = {row["arm"]: row for row in rows}
    met = {"delivered_r2": by.get("B r2", {}).get("delivered_ratio", 0) >= TARGETS["delivered_r2"],
           "delivered_r0": by.get("B r0", {}).get("delivered_ratio", 0) >= TARGETS["delivered_r0"],
           "whole_r0_no_larger_than_a": by.get("B r0", {}).get("whole_bytes", 1 << 62) <= a["whole_bytes"]}
    return {"benchmark": "one_object_storage", "date": date.today().isoformat(),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores", "quick": args.quick,
            "command": "python -m benchmarks.experiments.one_object_storage" + (" --quick" if args.quick else ""),
            "spec": "examples/studies/paper.yaml", "a": a, "arms": rows, "targets": TARGETS, "met": met}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=None, help="work folder, kept (a rerun reuses its jobs)")
    parser.add_argument("--in-process", action="store_true", help="run the jobs without Ray")
    parser.add_argument("--quick", action="store_true", help="4 objects x 40 candidates: a smoke test")
    parser.add_argument("--render", action="store_true", help="only render the page from the results JSON")
    parser.add_argument("--out", type=Path, default=ROOT, help="where benchmarks/results/ and docs/ are")
    args = parser.parse_args(argv)
    results = args.out / "benchmarks" / "results" / "one_object_storage.json"
    if args.render:
        out = json.loads(results.read_text())
    else:
        out = measure(args, args.folder or Path(tempfile.mkdtemp(prefix="onepiece-storage-")))
        results.parent.mkdir(parents=True, exist_ok=True)
        results.write_text(json.dumps(out, indent=2) + "\n")
    (args.out / "docs").mkdir(parents=True, exist_ok=True)
    write_page(out, args.out / "docs" / "one_object_storage.md")
    return out


if __name__ == "__main__":
    main()
