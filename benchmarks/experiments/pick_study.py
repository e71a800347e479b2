"""The study where it decides (issue 58, docs/studies/pick_labels): plans compared by the labels each needs to reach
a network that picks. Every arm (study.pick_study.arms: A every pick label, R random shares, B one grasp per voxel shape
at radii 0 and 1, R the size of each B) trains the design the pick issue keeps (pick_unseen.DESIGN, several seeds)
on the pick curve's labels (both batches: 81,152 candidates executed by the pick protocol on 634 training
objects); every network picks the household views at the first attempt (picks.networks: the same views and
candidates for all); the label's ceiling is measured on held-out candidates executed again and again.

    .venv/bin/python -m benchmarks.experiments.pick_study [--seeds 0,1,2] [--fits-only]

Steps are kept under data/pick_study (a run again fits, picks or draws only what it had not), the result goes to
docs/studies/pick_labels/study.json and its page is rendered beside it (study.pick_study.page).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import platform
from datetime import date

import numpy as np

from benchmarks.experiments.pick_study_judge import OUT, ROOT, STUDY_SEED, judged

PAGE = ROOT / "docs" / "studies" / "pick_labels"
SIZES = (500, 2000, 8000)  # R arms below the B sizes (those come with B)
RADII = (0, 1)


def study_labels():
    """The pick curve's first batch and its second, random: the labels every arm draws from."""
    from benchmarks.experiments.pick_curve import labels
    from benchmarks.experiments.pick_on_policy import second_batch

    return labels(1).joined(second_batch(None))


def arms_of(all_labels):
    from onepiece_dist.specs.job import GripperSpec, VoxelSpec
    from onepiece_dist.study.pick_study.arms import crop_codes, pick_arms

    spec = all_labels.attrs["spec"]
    voxel = VoxelSpec.model_validate(spec["voxel"])
    shape = voxel.grid_shape(GripperSpec.model_validate(spec["gripper"]))
    return pick_arms(crop_codes(all_labels.points, shape, voxel.resolution), SIZES, RADII, STUDY_SEED)


def fitted(all_labels, arm, seed: int) -> dict:
    """``arm``'s network at ``seed``: read back from its folder when fitted there on the same rows and design."""
    from benchmarks.experiments.pick_curve import fit_rows
    from benchmarks.experiments.pick_unseen import DESIGN

    folder = OUT / "fits" / f"{arm.name.replace(' ', '_').replace('~', '').replace(',', '')}_s{seed}"
    key = {"rows": hashlib.sha256(arm.rows.tobytes()).hexdigest()[:16], "design": DESIGN, "seed": seed,
           "labels": all_labels.attrs.get("specs")}
    record = folder / "fit.json"
    kept = json.loads(record.read_text()) if record.is_file() else {}
    if kept.get("key") == key:
        return kept["fit"]
    fit = fit_rows(all_labels, arm.rows, DESIGN, seed, folder)
    record.write_text(json.dumps({"key": key, "fit": fit}, indent=1) + "\n")
    print(f"fit {arm.name} s{seed}: {arm.labels} labels, {fit['fit_seconds']} s", flush=True)
    return fit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--fits-only", action="store_true")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    all_labels = study_labels()
    arms = arms_of(all_labels)
    print(", ".join(f"{a.name}: {a.labels}" for a in arms), flush=True)
    fits = {(arm.name, seed): fitted(all_labels, arm, seed) for arm in sorted(arms, key=lambda a: a.labels)
            for seed in seeds}
    if args.fits_only:
        return
    result = judged(all_labels, arms, seeds, fits)
    PAGE.mkdir(parents=True, exist_ok=True)
    result.update(command=".venv/bin/python -m benchmarks.experiments.pick_study", date=date.today().isoformat(),
                  machine=f"{platform.machine()}, {platform.processor() or 'cpu'}")
    (PAGE / "study.json").write_text(json.dumps(result, indent=1) + "\n")
    from onepiece_dist.study.pick_study.page import write_page

    write_page(PAGE)


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
