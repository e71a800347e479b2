"""Does a job's dataset depend on the CPU it ran on? Jobs run with this CPU's numpy, libm and BLAS paths turned off.

    .venv/bin/python -m benchmarks.experiments.bench_cpu_independence

x86-64 CPUs differ in what numpy (SIMD level: SVML on AVX-512), glibc's libm (FMA or plain variants), OpenBLAS
(kernel per CPU) and Embree (kernel per CPU and, on Intel, per model) pick for them, and in how many threads they
run; one ULP of a pose handed to pybullet can move a trial. Two jobs, each run in a fresh process on this CPU and
under each of tests/test_pinned_job.py's CPU settings (and the oldest-CPU ones at once), every array of the dataset
compared by digest:

  extract  the default job's extraction on 16 objects x 200 candidates (ingest, extract, dedup);
  pinned   tests/test_pinned_job.py's job (3 objects x 24 candidates, every stage to label).

And what the fixes buy, with the formulas they replaced patched back in (``--formula``):

  np.sin   the samplers' sines and cosines from numpy (one ULP from core.portable's in a few % of angles):
           how many settled poses and codes of the extract job that moves, on this CPU;
  blas     the one object's patches rotated by a BLAS matrix product instead of core.frames.rotate_points:
           how many of the pinned job's labels OpenBLAS's SSE kernel changes;
  embree   the antipodal sampler's hits as Embree reports them (float32) instead of core.raycast's, and the same
           with every distance one float32 ULP longer (what another Embree kernel may give): the pinned job's
           arrays that move, and whether the old formula gives the pins written before core.raycast.

Results: benchmarks/results/cpu_independence.json, rendered into docs/assembly.md by benchmarks/pages/report.py.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import os
import platform
import subprocess
import sys
import tempfile
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
EXTRACT_OBJECTS = "pybullet:named[0:4]+pybullet:random_urdfs[0:12]"
SAVED = ("grasps/pose", "grasps/code", "assembled/grasps/success", "assembled/grasps/code")
PINS_BEFORE_RAYCAST = {  # tests/data/pinned_job.json at 4fad3b1, the pins an AVX-512 Sapphire Rapids machine missed
    "grasps/code": "uint8 [59, 8] 6b8148ded9a9a16990907a7f",
    "assembled/grasps/code": "uint8 [230, 8] b12972e1c132cd850ddcc4ab",
    "assembled/grasps/success": "uint8 [230] 4a8542929f438b833825b938"}


FORMULAS = ("shipped", "np.sin", "blas", "embree", "embree+1ulp")


def job_spec(job: str, output: Path):
    from onepiece_dist.specs.job import JobSpec

    if job == "pinned":
        from tests.test_pinned_job import pinned_spec

        return pinned_spec(output)
    return JobSpec(objects=EXTRACT_OBJECTS, grasps_per_object=200, output=str(output),
                   stages=("ingest", "extract", "dedup"))


def patch_formula(formula: str) -> None:
    """Put back the formula a fix replaced, in this process only."""
    if formula == "np.sin":
        import onepiece_dist.core.sampling as sampling

        sampling.sin_cos = lambda angle: (np.sin(angle), np.cos(angle))
    elif formula == "blas":
        import onepiece_dist.job.patches as patches

        patches.rotate_points = lambda points, rot: np.asarray(points, dtype=np.float64) @ rot
    elif formula in ("embree", "embree+1ulp"):
        import onepiece_dist.core.sampling as sampling

        sampling.cast_rays = functools.partial(embree_hits, ulps=int(formula == "embree+1ulp"))


def embree_hits(vertices, faces, origins, directions, ulps: int = 0):
    """The ray casts as they were before core.raycast: Embree's float32 distances and normals themselves, with
    ``ulps`` float32 ULPs added to each distance (what another Embree kernel may report)."""
    import open3d as o3d

    from onepiece_dist.core.raycast import RayHits

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))
    hit = scene.cast_rays(o3d.core.Tensor(np.hstack([origins, directions]).astype(np.float32)))
    t = hit["t_hit"].numpy()
    for _ in range(ulps):
        t = np.nextafter(t, np.float32(np.inf))
    face = hit["primitive_ids"].numpy().astype(np.int64)
    return RayHits(t.astype(np.float64), np.where(np.isfinite(t), face, -1),
                   hit["primitive_normals"].numpy().astype(np.float64))


def run_one(job: str, formula: str, keep: Path) -> dict[str, str]:
    """Run ``job`` in this process; save the arrays in SAVED to ``keep`` (.npz). -> {array: digest}"""
    import zarr

    from onepiece_dist.runtime.local import run_local

    patch_formula(formula)
    with tempfile.TemporaryDirectory() as scratch:
        output = Path(scratch) / "job.zarr"
        run_local(job_spec(job, output))
        root, digests, saved = zarr.open_group(str(output), mode="r"), {}, {}
        for name, array in _walk(root):
            values = np.ascontiguousarray(array[...])
            digests[name] = hashlib.blake2b(values.tobytes(), digest_size=12).hexdigest()
            if name in SAVED:
                saved[name.replace("/", ".")] = values
    np.savez(keep, **saved)
    return digests


def _walk(group, prefix: str = ""):
    import zarr

    for name, member in group.members():
        if isinstance(member, zarr.Group):
            yield from _walk(member, f"{prefix}{name}/")
        else:
            yield f"{prefix}{name}", member


def in_process(job: str, env: dict[str, str], formula: str, keep: Path) -> dict[str, str]:
    """``run_one`` in a fresh Python with ``env`` added (the CPU settings take effect at library load)."""
    command = [sys.executable, "-m", "benchmarks.experiments.bench_cpu_independence", "--one", job, "--formula",
               formula, "--keep", str(keep)]
    out = subprocess.run(command, capture_output=True, text=True, env={**os.environ, **env}, timeout=900, cwd=ROOT)
    if out.returncode != 0:
        raise RuntimeError(f"{job} ({env}, {formula}) failed: {out.stderr[-2000:]}")
    return json.loads(out.stdout.splitlines()[-1])


def differing(a: dict[str, str], b: dict[str, str]) -> list[str]:
    return sorted(name for name in a.keys() | b.keys() if a.get(name) != b.get(name))


def cpu_settings() -> dict[str, dict[str, str]]:
    """tests/test_pinned_job.py's CPU settings, and the oldest-CPU ones at once."""
    from tests.test_pinned_job import ONE_CPU
    from tests.test_pinned_job import cpu_settings as pinned_settings

    settings = pinned_settings()
    oldest = ("one thread, one CPU", "OpenBLAS SSE kernel", "numpy without AVX2 or AVX-512",
              "glibc without AVX, AVX2, FMA")
    settings["the oldest at once"] = {k: v for name in oldest if name in settings for k, v in settings[name].items()}
    assert ONE_CPU in settings["the oldest at once"]
    return settings


def settings_rows(job: str, folder: Path, settings: dict[str, dict[str, str]]) -> tuple[dict, list[dict]]:
    """The job on this CPU and under each CPU setting: arrays, and those that differ."""
    base = in_process(job, {}, "shipped", folder / f"{job}-this.npz")
    rows = []
    for name, env in settings.items():
        found = in_process(job, env, "shipped", folder / f"{job}-{len(rows)}.npz")
        rows.append({"job": job, "setting": name, "arrays": len(base), "differing": differing(base, found)})
    return base, rows


def sine_sensitivity(folder: Path) -> dict:
    """The extract job with numpy's sines in the samplers against core.portable's, on this CPU."""
    from onepiece_dist.core.portable import sin_cos

    angles = np.random.default_rng(0).uniform(0, 4 * np.pi, 200_000)
    sin, cos = sin_cos(angles)
    moved_values = float(np.mean((sin != np.sin(angles)) | (cos != np.cos(angles))))
    in_process("extract", {}, "np.sin", folder / "extract-np-sin.npz")
    a, b = np.load(folder / "extract-this.npz"), np.load(folder / "extract-np-sin.npz")
    same_rows = len(a["grasps.pose"]) == len(b["grasps.pose"])
    moved = np.abs(a["grasps.pose"] - b["grasps.pose"]).max(axis=(1, 2)) if same_rows else None
    return {"angles_with_another_sine_or_cosine": round(moved_values, 4), "grasps": len(a["grasps.pose"]),
            "grasps_with_numpy_sines": len(b["grasps.pose"]),
            "settled_poses_moved_over_1e-4": int((moved > 1e-4).sum()) if same_rows else None,
            "codes_changed": int((a["grasps.code"] != b["grasps.code"]).any(axis=1).sum()) if same_rows else None}


def blas_patch_labels(folder: Path) -> dict:
    """The pinned job with BLAS-rotated patches, on this CPU and under OpenBLAS's SSE kernel: labels changed."""
    this = folder / "pinned-blas-this.npz"
    sse = folder / "pinned-blas-sse.npz"
    in_process("pinned", {}, "blas", this)
    in_process("pinned", {"OPENBLAS_CORETYPE": "Prescott"}, "blas", sse)
    a, b = (np.load(p)["assembled.grasps.success"] for p in (this, sse))
    return {"labels": len(a), "labels_under_sse": len(b),
            "labels_changed": int(np.sum(a != b)) if len(a) == len(b) else None}


def embree_sensitivity(folder: Path) -> dict:
    """The pinned job with Embree's own float32 hits in the antipodal sampler, and with each of their distances
    one float32 ULP longer: which arrays move, and whether that formula gives the pins written before core.raycast."""
    runs = {formula: in_process("pinned", {}, formula, folder / f"pinned-{formula}.npz")
            for formula in ("embree", "embree+1ulp")}
    a, b = (np.load(folder / f"pinned-{formula}.npz") for formula in runs)
    pins = {name: "{} {} {}".format(a[name.replace("/", ".")].dtype, list(a[name.replace("/", ".")].shape),
                                    runs["embree"][name]) for name in PINS_BEFORE_RAYCAST}
    same_rows = a["assembled.grasps.success"].shape == b["assembled.grasps.success"].shape
    return {"arrays": len(runs["embree"]), "differing": differing(*runs.values()),
            "reproduces_pins_before_raycast": pins == PINS_BEFORE_RAYCAST,
            "labels": len(a["assembled.grasps.success"]), "labels_after": len(b["assembled.grasps.success"]),
            "labels_changed": int(np.sum(a["assembled.grasps.success"] != b["assembled.grasps.success"]))
            if same_rows else None,
            "extraction_codes_changed": int(np.any(a["grasps.code"] != b["grasps.code"], axis=1).sum())
            if a["grasps.code"].shape == b["grasps.code"].shape else None}


def cpu_model() -> str:
    lines = Path("/proc/cpuinfo").read_text().splitlines() if Path("/proc/cpuinfo").is_file() else []
    return next((line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")), "unknown CPU")


CPU_START = "<!-- cpu: rendered by benchmarks/pages/report.py from benchmarks/results/cpu_independence.json -->"
CPU_END = "<!-- end of cpu -->"


def cpu_section(r: dict) -> str:
    """docs/assembly.md's block on the same dataset on every CPU, from this benchmark's results."""
    def described(env: dict) -> str:
        return ", ".join(f"`{k}={v}`" for k, v in env.items())

    rows = [[f"{row['job']} ({row['arrays']} arrays)", row["setting"],
             ", ".join(f"`{name}`" for name in row["differing"]) or "none"] for row in r["rows"]]
    moved = sorted({name for row in r["rows"] for name in row["differing"]})
    sines, blas, embree = r["numpy_sines"], r["blas_patches"], r["embree_hits"]
    return "\n".join([
        CPU_START, f"**Figures:** `{r['command']}` ({r['date']}, {r['machine']}). Each job in a fresh process on "
        "this CPU and with its paths changed (" + "; ".join(f"{name}: {described(env)}" for name, env in
                                                            r["settings"].items())
        + f"); every array of the dataset compared by digest. extract: `{r['extract_objects']}` x 200 candidates, "
        "ingest to dedup; pinned: tests/test_pinned_job.py's job, every stage to label.", "",
        "| job | setting | arrays that differ from this CPU's |", "| --- | --- | --- |",
        *[f"| {' | '.join(row)} |" for row in rows], "",
        "Target, every array the same under every setting: " + ("met." if not moved else
                                                               f"not met ({', '.join(moved)}).")
        + f" What the fixes buy, with the formulas they replaced put back: numpy's sines in the samplers (another "
        f"sine or cosine for {sines['angles_with_another_sine_or_cosine']:.1%} of angles) moved "
        f"{sines['settled_poses_moved_over_1e-4']} of {sines['grasps']:,} settled poses by more than 1e-4 and "
        f"changed {sines['codes_changed']} codes of the extract job on this CPU; patches rotated by a BLAS product "
        f"changed {blas['labels_changed']} of the pinned job's {blas['labels']} labels under OpenBLAS's SSE kernel; "
        f"with Embree's own float32 ray hits in the antipodal sampler (the pins before core.raycast: "
        f"{'reproduced' if embree['reproduces_pins_before_raycast'] else 'not reproduced'}), one float32 ULP more on "
        f"every hit distance moved {len(embree['differing'])} of the pinned job's {embree['arrays']} arrays, "
        + _moved_codes_and_labels(embree) + ".",
        CPU_END])


def _moved_codes_and_labels(embree: dict) -> str:
    codes = embree["extraction_codes_changed"]
    words = [f"{codes:,} extraction codes" if codes is not None else "the number of extracted grasps"]
    if embree["labels_changed"] is not None:
        words.append(f"{embree['labels_changed']} of its {embree['labels']} labels")
    else:
        words.append(f"the number of its labelled grasps ({embree['labels']} to {embree['labels_after']})")
    return " and ".join(words)


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", choices=("extract", "pinned"), help=argparse.SUPPRESS)
    parser.add_argument("--formula", default="shipped", choices=FORMULAS, help=argparse.SUPPRESS)
    parser.add_argument("--keep", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        from tests.test_pinned_job import ONE_CPU

        if os.environ.get(ONE_CPU):
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        print(json.dumps(run_one(args.one, args.formula, args.keep)))
        return {}
    settings = cpu_settings()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        rows = settings_rows("extract", folder, settings)[1] + settings_rows("pinned", folder, settings)[1]
        out = {"benchmark": "cpu_independence", "date": date.today().isoformat(),
               "machine": f"{platform.machine()}, {cpu_model()}, {os.cpu_count()} cores", "settings": settings,
               "extract_objects": EXTRACT_OBJECTS, "rows": rows, "numpy_sines": sine_sensitivity(folder),
               "blas_patches": blas_patch_labels(folder), "embree_hits": embree_sensitivity(folder),
               "command": "python -m benchmarks.experiments.bench_cpu_independence"}
    (HERE / "results" / "cpu_independence.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
