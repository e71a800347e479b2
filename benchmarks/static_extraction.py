"""Would crops at the candidate pose (no physics in extraction) lift the paper experiment's time ratio? A cost
projection from measured figures, without labelling or training.

    .venv/bin/python -m benchmarks.static_extraction [--objects 64] [--grasps 2000] [--radii 0,1,2]

Runs the extraction of arm B static of benchmarks/paper_experiment.py (same objects, candidates, seed and spec;
ingest, extract and dedup, one process, one thread, a fresh folder) and counts its shapes at each radius. Its
cost if it were labelled on the one object = its extraction core-seconds + shapes x the per-shape cost (assemble +
label) that the committed experiment measured for B r0 (benchmarks/results/paper_experiment.json); the ratio is
A's core-seconds over that, beside the settled B arm of the same radius as the experiment measured it.
Writes benchmarks/results/static_extraction.json.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the experiment's single-process jobs

import json
import platform
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
from benchmarks import paper_experiment  # noqa: E402
from onepiece_dist.core.dedup import unique_codes  # noqa: E402
from onepiece_dist.core.similar import similar_clusters  # noqa: E402
from onepiece_dist.spec import JobSpec  # noqa: E402


def static_job(objects: int, grasps: int, folder: Path) -> JobSpec:
    """The experiment's B static spec, cut to ingest, extract and dedup, writing into ``folder``."""
    args = paper_experiment.parse_args(["--objects", str(objects), "--grasps", str(grasps), "--static-radii", "0"])
    spec = JobSpec.model_validate_json(paper_experiment.generation_specs(args, folder)["B static"][0])
    return spec.model_copy(update={"stages": ("ingest", "extract", "dedup"), "output": str(folder / "static.zarr"),
                                   "cache_dir": str(folder / "parts")})


def shapes_by_radius(path: str, radii: list[int]) -> tuple[int, dict[int, int]]:
    """Grasps of the dataset at ``path`` and its clusters at each radius."""
    from onepiece_dist.store import open_dataset

    ds = open_dataset(path)
    exact = unique_codes(ds["grasps/code"])
    nbits = int(np.prod(ds.attrs["grid_shape"]))
    return len(exact.inverse), {r: len(similar_clusters(exact.unique, exact.counts, nbits, r).representative)
                                for r in radii}


def projection(experiment: dict, extraction_seconds: float, shapes: dict[int, int]) -> list[dict]:
    arms = {row["arm"]: row for row in experiment["arms"]}
    a, patch = arms["A"]["core_seconds"], experiment["cost_curve"]["per_unit_seconds"]["patch"]
    rows = []
    for radius, count in shapes.items():
        seconds = extraction_seconds + count * patch
        settled = arms.get(f"B r{radius}")
        rows.append({"radius": radius, "shapes": count, "projected_core_seconds": round(seconds, 1),
                     "projected_time_ratio": round(a / seconds, 3),
                     "settled": {"shapes": settled["unique_codes"], "core_seconds": settled["core_seconds"],
                                 "time_ratio": settled["time_ratio"]} if settled else None})
    return rows


def main(argv=None) -> dict:
    import argparse

    from onepiece_dist.service.local import run_local

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=64)
    parser.add_argument("--grasps", type=int, default=2000)
    parser.add_argument("--radii", default="0,1,2")
    args = parser.parse_args(argv)
    experiment = json.loads((HERE / "results" / "paper_experiment.json").read_text())
    with tempfile.TemporaryDirectory(prefix="onepiece-static-") as tmp:
        spec = static_job(args.objects, args.grasps, Path(tmp))
        start = time.perf_counter()
        status = run_local(spec, job_id="static-extraction")
        wall = time.perf_counter() - start
        grasps, shapes = shapes_by_radius(spec.output, [int(r) for r in args.radii.split(",")])
    extraction = sum(status.timings.get(s, 0.0) for s in ("ingest", "extract", "dedup"))
    settled = {row["arm"]: row for row in experiment["arms"]}.get("B r0")
    out = {"benchmark": "static_extraction", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores (one used)", "objects": args.objects,
           "candidates_per_object": args.grasps, "grasps": grasps, "wall_seconds": round(wall, 1),
           "stages": {k: round(v, 1) for k, v in status.timings.items()},
           "extraction_core_seconds": round(extraction, 1),
           "settled_extraction_core_seconds": round(sum(settled["stages"].get(s, 0.0)
                                                        for s in ("ingest", "extract", "dedup")), 1),
           "settled_grasps": settled["extracted_grasps"],
           "patch_seconds": experiment["cost_curve"]["per_unit_seconds"]["patch"],
           "a_core_seconds": {row["arm"]: row for row in experiment["arms"]}["A"]["core_seconds"],
           "experiment": experiment["command"].strip(), "rows": projection(experiment, extraction, shapes),
           "command": "python -m benchmarks.static_extraction " + " ".join(sys.argv[1:] if argv is None else argv)}
    (HERE / "results" / "static_extraction.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
