"""ACRONYM's public example grasps (the mug in NVlabs/acronym) relabelled by our protocol (issue 50).

    python -m benchmarks.experiments.relabel_acronym [--acronym PATH/TO/acronym]
    # writes results/relabel_acronym.json, then docs/relabel.md

The mug's 2,000 Panda grasps (their flex label: object_in_gripper) and its mesh are read from a clone of
NVlabs/acronym at ACRONYM_COMMIT (``--acronym``), else fetched from GitHub into ~/.cache/onepiece/acronym/ (never
committed). Each setting runs ``onepiece label --grasps`` in process: our protocol (Panda preset, 4 trials that
must all hold, pads' friction 0.4) on VHACD's and on CoACD's pieces, and on CoACD's with ACRONYM's own physics
(friction 1, density 150 kg/m^3, as the file records) to tell the physics apart from the protocol.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
import urllib.request
from pathlib import Path

import zarr

from benchmarks.pages.committed import RESULTS
from onepiece_dist.api import relabel_report, relabel_spec, resolve_source, run_job
from onepiece_dist.specs.job import JobSpec

ACRONYM_COMMIT = "d02f58fb3a556c3b719976e206cce0dce0103199"
GRASPS = "data/examples/grasps/Mug_10f6e09036350e92b3f21f1137c3c347_0.0002682457830986903.h5"
MESH = "data/examples/meshes/Mug/10f6e09036350e92b3f21f1137c3c347.obj"
CACHE = Path.home() / ".cache" / "onepiece" / "acronym"
SETTINGS = {
    "ours_vhacd": {"sim": {"collision": "vhacd"}},
    "ours_coacd": {"sim": {"collision": "coacd"}},
    "acronym_physics_coacd": {"sim": {"collision": "coacd", "density": 150.0}, "gripper_friction": 1.0},
}


def example_files(clone: Path | None) -> Path:
    """The grasp file, in its grasps/ folder beside meshes/ (the data root ACRONYM ships)."""
    root = clone if clone is not None else CACHE / ACRONYM_COMMIT[:12]
    if clone is None and not (root / GRASPS).is_file():
        for relative in (GRASPS, MESH):
            url = f"https://raw.githubusercontent.com/NVlabs/acronym/{ACRONYM_COMMIT}/{relative}"
            (root / relative).parent.mkdir(parents=True, exist_ok=True)
            with urllib.request.urlopen(url, timeout=60) as response:
                (root / relative).write_bytes(response.read())
    return root / GRASPS


def run_setting(grasps: Path, folder: Path, options: dict) -> dict:
    base = JobSpec.model_validate({"sim": {"label_trials": 4, "success": "every_trial", **options["sim"]}})
    spec = relabel_spec([grasps], folder / "mug.zarr", base=base)
    if "gripper_friction" in options:
        spec = spec.model_copy(update={"gripper": spec.gripper.model_copy(
            update={"friction": options["gripper_friction"]})})
    start = time.perf_counter()
    run_job(spec, in_process=True)
    seconds = time.perf_counter() - start
    report = relabel_report(spec.output, resolve_source(spec.objects))
    part = next(Path(f"{spec.output}.parts").glob("*.zarr"))  # the mug's one part: its trials' outcomes
    dropped = {k: v for k, v in zarr.open_group(str(part), mode="r").attrs.items() if k.startswith("dropped_")}
    return {"report": json.loads(report.to_json()), "seconds": round(seconds, 1), "dropped": dropped,
            "gripper": spec.gripper.name, "friction": spec.gripper.friction, "density": spec.sim.density,
            "collision": spec.sim.collision}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--acronym", type=Path, help="a clone of NVlabs/acronym (default: fetched from GitHub)")
    args = parser.parse_args()
    grasps = example_files(args.acronym)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, options in SETTINGS.items():
            folder = Path(tmp) / name
            folder.mkdir()
            results[name] = run_setting(grasps, folder, options)
            print(name, json.dumps(results[name]["report"]["overall"]), flush=True)
            shutil.rmtree(folder)
    out = {"source": f"NVlabs/acronym@{ACRONYM_COMMIT[:12]} {GRASPS}", "settings": results}
    (RESULTS / "relabel_acronym.json").write_text(json.dumps(out, indent=1) + "\n")
    from benchmarks.pages.report import write_page

    write_page("docs/relabel.md")


if __name__ == "__main__":
    main()
