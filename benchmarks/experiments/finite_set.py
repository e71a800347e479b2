"""Is the set of in-gripper shapes finite? Unique codes against the number of objects (issue 43, item 3).

    .venv/bin/python -m benchmarks.experiments.finite_set [--objects 512] [--grasps 500] [--folder DIR] [--quick]

The paper's premise is that at the network's voxel resolution the in-gripper shapes form a finite, highly repeated
set. Its experiment grew the candidates per object (250 to 2,000 on 64 objects), never the objects. This grows the
objects: one extraction job (settle, crop, code; the paper's normal-direction sampler, no labels) on pybullet's
named objects and random_urdfs, then, for 8 to N objects (the first N of 5 seeded orders), the unique codes:
exact and merged within Hamming radius 1 and 2 at 10 mm (the job's codes), and exact at 5 and 20 mm (the same
settled poses cropped again from each object's stored surface points). Two curves are fitted to each: a power law
U = a N^b (b < 1 grows ever slower but never stops) and a saturation U = U_max N / (K + N) (a finite set of U_max
shapes); the page gives both, which fits better, and what each predicts at 10,000 objects.

Writes benchmarks/results/finite_set.json, docs/finite_set.md and docs/finite_set.png (``--render``: the page and
plot again from the JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np

from benchmarks.pages.finite_set_page import plot, write_page
from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.similar import similar_clusters
from onepiece_dist.specs.job import JobSpec

ROOT = Path(__file__).resolve().parents[2]
ORDERS = 5  # seeded object orders: the spread of U at each N
PREDICT_AT = 10_000


def sizes(total: int) -> list[int]:
    """8, 16, 32, ... up to ``total`` (and ``total`` itself)."""
    out = [n for n in (8, 16, 32, 64, 128, 256, 512, 1024) if n < total]
    return [*out, total]


def source(count: int) -> str:
    """pybullet's 9 named objects, then random_urdfs from 0: ``count`` objects in all."""
    return f"pybullet:named+pybullet:random_urdfs[0:{max(count - 9, 0)}]"


def extraction_spec(args, folder: Path) -> JobSpec:
    return JobSpec(objects=source(args.objects), grasps_per_object=args.grasps, seed=0, sampler={"method": "normal"},
                   output=str(folder / "extract.zarr"), stages=("ingest", "extract", "dedup"),
                   sim={"points_per_grasp": 0, "transfer_codes": 0})


def codes_at(spec: JobSpec, resolution_mm: float) -> tuple[np.ndarray, int]:
    """(N, B) codes of every extracted grasp at ``resolution_mm``, cropped at its settled pose from its object's
    stored surface points (the job's own codes at its resolution), and the code's bit count."""
    from onepiece_dist.core.voxel import crop_codes
    from onepiece_dist.job.patches import source_geometry
    from onepiece_dist.store import PartStore, open_dataset

    reader = open_dataset(spec.output)
    voxel = spec.voxel.model_copy(update={"resolution": resolution_mm / 1000})
    grid = voxel.grid_shape(spec.gripper)
    nbits = int(np.prod(grid))
    if abs(voxel.resolution - spec.voxel.resolution) < 1e-12:
        return reader["grasps/code"], nbits
    owner, poses = reader["grasps/object"].astype(np.int64), reader["grasps/pose"].astype(np.float64)
    codes = np.zeros((len(owner), (nbits + 7) // 8), dtype=np.uint8)
    parts = PartStore(spec.parts_folder())
    for obj in np.unique(owner):
        surface = source_geometry(reader, parts, int(obj)).surface
        codes[owner == obj] = crop_codes(surface, poses[owner == obj], grid, voxel.resolution)[0]
    return codes, nbits


def growth(codes: np.ndarray, owner: np.ndarray, nbits: int, radius: int, counts: list[int]) -> list[dict]:
    """Unique codes (clusters within ``radius``) among the grasps of the first N objects of each seeded order."""
    objects = np.unique(owner)
    rows = []
    for n in counts:
        values, grasps = [], []
        for order in range(ORDERS):
            chosen = np.isin(owner, np.random.default_rng([order, 43]).permutation(objects)[:n])
            exact = unique_codes(codes[chosen])
            values.append(len(exact.unique) if radius == 0 else
                          len(similar_clusters(exact.unique, exact.counts, nbits, radius).representative))
            grasps.append(int(chosen.sum()))
        rows.append({"objects": n, "unique_mean": float(np.mean(values)), "unique_min": int(min(values)),
                     "unique_max": int(max(values)), "grasps_mean": float(np.mean(grasps))})
    return rows


def power_law(n: np.ndarray, u: np.ndarray) -> dict:
    """U = a N^b by least squares in log-log."""
    b, log_a = np.polyfit(np.log(n), np.log(u), 1)
    return {"a": float(np.exp(log_a)), "exponent": float(b)}


def saturation(n: np.ndarray, u: np.ndarray) -> dict:
    """U = U_max N / (K + N) by least squares; {} when no such curve fits."""
    import warnings

    from scipy.optimize import OptimizeWarning, curve_fit

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OptimizeWarning)
            (top, half), _ = curve_fit(_saturating, n, u, p0=(2 * u[-1], n[-1]), bounds=([0, 0], [1e12, 1e9]),
                                       maxfev=20000)
    except RuntimeError:
        return {}
    return {"u_max": float(top), "half_objects": float(half)}


def _saturating(x, top, half):
    return top * x / (half + x)


def predict(model: dict, n) -> float | np.ndarray:
    if "exponent" in model:
        return model["a"] * np.asarray(n, dtype=np.float64) ** model["exponent"]
    return _saturating(np.asarray(n, dtype=np.float64), model["u_max"], model["half_objects"])


def fit(rows: list[dict]) -> dict:
    """Both curves fitted to the mean unique codes against objects: each one's RMS error in log U, its prediction
    at PREDICT_AT objects, and (with 4 or more sizes) its error when fitted without the largest size and asked to
    predict it: the out-of-sample test that decides which curve describes the growth."""
    n = np.array([r["objects"] for r in rows], dtype=np.float64)
    u = np.array([r["unique_mean"] for r in rows], dtype=np.float64)
    out = {}
    for name, model in (("power_law", power_law(n, u)), ("saturation", saturation(n, u))):
        if not model:
            out[name] = {"error": "no curve of this form fits"}
            continue
        model["rms_log_error"] = float(np.sqrt(np.mean((np.log(predict(model, n)) - np.log(u)) ** 2)))
        model["predicted"] = float(predict(model, PREDICT_AT))
        if len(n) >= 4:
            early = power_law(n[:-1], u[:-1]) if name == "power_law" else saturation(n[:-1], u[:-1])
            model["largest_predicted_from_the_rest"] = float(predict(early, n[-1])) if early else None
        out[name] = model
    judged = "largest_predicted_from_the_rest" if len(n) >= 4 else "rms_log_error"

    def error(name: str) -> float:
        model = out[name]
        if judged == "rms_log_error":
            return model.get("rms_log_error", np.inf)
        guess = model.get(judged)
        return abs(np.log(guess / u[-1])) if guess else np.inf

    out["better_fit"] = "saturation" if error("saturation") < error("power_law") else "power law"
    out["judged_by"] = "predicting the largest size from the others" if len(n) >= 4 else "RMS log error"
    last, before = rows[-1], rows[-2] if len(rows) > 1 else rows[-1]
    out["new_codes_per_object_at_end"] = round((last["unique_mean"] - before["unique_mean"])
                                               / max(last["objects"] - before["objects"], 1), 2)
    return out


def measure(args, folder: Path) -> dict:
    from onepiece_dist.api import run_job
    from onepiece_dist.store import open_dataset
    from onepiece_dist.study.jobs import finished

    spec = extraction_spec(args, folder)
    start = time.perf_counter()
    status = finished(spec) or run_job(spec, in_process=args.in_process)
    seconds = time.perf_counter() - start
    owner = open_dataset(spec.output)["grasps/object"].astype(np.int64)
    counts = sizes(len(np.unique(owner)))
    curves = []
    for mm, radii in ((10.0, (0, 1, 2)), (5.0, (0,)), (20.0, (0,))):
        codes, nbits = codes_at(spec, mm)
        for radius in radii:
            rows = growth(codes, owner, nbits, radius, counts)
            curves.append({"resolution_mm": mm, "radius": radius, "code_bits": nbits, "rows": rows, "fit": fit(rows)})
    return {"benchmark": "finite_set", "date": date.today().isoformat(),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores",
            "command": "python -m benchmarks.experiments.finite_set " + " ".join(args.argv),
            "objects_source": spec.objects, "grasps_per_object": spec.grasps_per_object,
            "objects_ok": int(len(np.unique(owner))), "grasps": int(len(owner)),
            "rejected": len(status.rejections), "extraction_wall_seconds": round(seconds, 1),
            "objects_reused": status.progress.objects_reused,
            "extraction_core_seconds": round(status.part_seconds, 1), "orders": ORDERS, "predict_at": PREDICT_AT,
            "curves": curves}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", type=int, default=512)
    parser.add_argument("--grasps", type=int, default=500)
    parser.add_argument("--folder", type=Path, default=None, help="work folder, kept (a rerun reuses its job)")
    parser.add_argument("--in-process", action="store_true", help="extract without Ray")
    parser.add_argument("--quick", action="store_true", help="16 objects x 40 candidates: a smoke test")
    parser.add_argument("--out", type=Path, default=ROOT, help="where benchmarks/results/ and docs/ are")
    parser.add_argument("--render", action="store_true", help="only render the page from the results JSON")
    args = parser.parse_args(argv)
    results = args.out / "benchmarks" / "results" / "finite_set.json"
    if args.render:
        out = json.loads(results.read_text())
        plot(out, args.out / "docs" / "finite_set.png")
        write_page(out, args.out / "docs" / "finite_set.md")
        return out
    args.argv = list(argv if argv is not None else __import__("sys").argv[1:])
    if args.quick:
        args.objects, args.grasps = 16, 40
    import tempfile

    folder = args.folder or Path(tempfile.mkdtemp(prefix="onepiece-finite-"))
    out = measure(args, folder)
    (args.out / "benchmarks" / "results").mkdir(parents=True, exist_ok=True)
    (args.out / "docs").mkdir(parents=True, exist_ok=True)
    results.write_text(json.dumps(out, indent=2) + "\n")
    plot(out, args.out / "docs" / "finite_set.png")
    write_page(out, args.out / "docs" / "finite_set.md")
    return out


if __name__ == "__main__":
    main()
