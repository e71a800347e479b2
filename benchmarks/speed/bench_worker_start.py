"""A worker's fixed costs per object and per process (issue 57: the suite's time is mostly these): VHACD in one
child that serves every object of a process against a fresh child per object (the way before, the baseline), and
open3d imported without its plotly front end against a plain ``import open3d``, both measured in the same run.

    .venv/bin/python -m benchmarks.speed.bench_worker_start

CPU seconds are this process's and its children's (getrusage), so a child's start counts. The served child must
write the same bytes as the fresh one for every object (checked; the run fails otherwise). Targets: each at least
1.5x less CPU than its baseline. Results: benchmarks/results/worker_start.json, rendered into docs/decomposition.md
by benchmarks/pages/report.py.
"""

from __future__ import annotations

import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
OBJECTS = "primitives[0:8]+pybullet:random_urdfs[0:8]"
IMPORTS = 5  # fresh processes per way of importing open3d
TARGET = 1.5
FRESH_CHILD = """
import sys, pybullet as p
p.connect(p.DIRECT)
p.vhacd(sys.argv[1], sys.argv[2], sys.argv[3], resolution=int(sys.argv[4]), maxNumVerticesPerCH=32)
"""
PLAIN_IMPORT = "import open3d"
OUR_IMPORT = "from onepiece_dist.core.raycast import import_open3d; import_open3d()"


def cpu_seconds() -> float:
    """CPU seconds of this process and of its children that have ended."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def measured(work) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of ``work()``."""
    wall, cpu = time.perf_counter(), cpu_seconds()
    work()
    return time.perf_counter() - wall, cpu_seconds() - cpu


def decompositions(folder: Path) -> dict:
    """Each object's VHACD by a fresh child and by the served one; the bytes compared."""
    from onepiece_dist.objects import load_object, resolve_source
    from onepiece_dist.objects.meshio import write_obj
    from onepiece_dist.sim import collision
    from onepiece_dist.specs.job import JobSpec

    meshes = [load_object(ref, JobSpec()).mesh for ref in resolve_source(OBJECTS)]
    sources = [folder / f"{mesh.content_id}.obj" for mesh in meshes]
    for mesh, source in zip(meshes, sources, strict=True):
        write_obj(mesh.vertices, mesh.faces, source)

    def fresh() -> None:
        for source in sources:
            subprocess.run([sys.executable, "-c", FRESH_CHILD, str(source), f"{source}.fresh", os.devnull, "50000"],
                           capture_output=True, check=True)

    def served() -> None:
        for mesh in meshes:
            collision.convex_pieces(mesh, folder / "served")
        collision._VHACD.close()  # its CPU counted as a child's: it must have ended

    fresh_wall, fresh_cpu = measured(fresh)
    served_wall, served_cpu = measured(served)
    differ = [mesh.name for mesh, source in zip(meshes, sources, strict=True)
              if Path(f"{source}.fresh").read_bytes() != (folder / "served" / f"{source.stem}-vhacd50000.obj")
              .read_bytes()]
    if differ:
        raise SystemExit(f"the served child wrote other pieces than a fresh child for {differ}")
    return {"objects": len(meshes), "fresh_child": {"wall_seconds": round(fresh_wall, 3), "cpu_seconds":
            round(fresh_cpu, 3)}, "served_child": {"wall_seconds": round(served_wall, 3), "cpu_seconds":
            round(served_cpu, 3)}, "same_bytes": True, "cpu_ratio": round(fresh_cpu / served_cpu, 2)}


def imports() -> dict:
    """CPU seconds of a fresh process that imports open3d, plainly and without plotly (median of IMPORTS)."""
    def one(code: str) -> float:
        return measured(lambda: subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                                               cwd=HERE.parent))[1]

    plain = statistics.median(one(PLAIN_IMPORT) for _ in range(IMPORTS))
    ours = statistics.median(one(OUR_IMPORT) for _ in range(IMPORTS))
    return {"processes": IMPORTS, "plain_cpu_seconds": round(plain, 3), "without_plotly_cpu_seconds": round(ours, 3),
            "cpu_ratio": round(plain / ours, 2)}


def main() -> None:
    with tempfile.TemporaryDirectory() as scratch:
        vhacd = decompositions(Path(scratch))
    result = {"command": ".venv/bin/python -m benchmarks.speed.bench_worker_start", "date": str(date.today()),
              "machine": f"{platform.machine()}, {os.cpu_count()} cores", "target": TARGET, "source": OBJECTS,
              "vhacd": vhacd, "open3d_import": imports()}
    (HERE / "results" / "worker_start.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
