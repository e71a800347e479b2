"""Positive rate of the label rules on unseen objects: what share of candidates each binary label calls a success.

Run: .venv/bin/python -m benchmarks.experiments.label_rules
     (writes benchmarks/results/label_rules.json; about 1 minute)
One single-process job labels the held-out objects of the paper's experiment (random_urdfs 500 on, never train
objects) with the paper's normal-direction sampler, the default physics and K = 4 label trials, then reads the
rates off the stored labels: the nominal trial held (``sim.success: nominal``), all K trials held
(``every_trial``), at least half of them held, and the nominal trial held with the object slipping less than a
threshold in the hand. docs/trials.md ("Label rule") explains the choice. Then the same candidates with the
label trials lifting a payload at the grasp centre (``sim.load: grasp``) of PAYLOADS kg: each payload's rates.
"""

from __future__ import annotations

import json
import platform
import tempfile
from datetime import date
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
from onepiece_dist.runtime.local import run_local  # noqa: E402
from onepiece_dist.specs.job import JobSpec  # noqa: E402
from onepiece_dist.store import open_dataset  # noqa: E402

OBJECTS, GRASPS, TRIALS = "pybullet:random_urdfs[500:516]", 60, 4
PAYLOADS = (0.25, 0.5, 1.0)  # kg


def rule_rates(success: np.ndarray, quality: np.ndarray, slip: np.ndarray) -> dict:
    """Positive rate of each rule over held grasps: success (n,) nominal outcome, quality (n,) success fraction
    over K trials, slip (n,) object motion in the hand while shaken (m)."""
    rates = {"nominal": success.mean(), "every_trial": (quality >= 1.0).mean(),
             "half_the_trials": (quality >= 0.5).mean()}
    rates.update({f"nominal_slip_below_{mm}mm": (success & (slip < mm / 1000)).mean() for mm in (5, 10, 20)})
    return {name: round(float(value), 4) for name, value in rates.items()}


def labelled(folder: str, name: str, **sim) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """success (n,) bool, quality (n,), slip (n,) of the held grasps of one single-process labelling job."""
    spec = JobSpec(objects=OBJECTS, grasps_per_object=GRASPS, seed=1, sampler={"method": "normal"},
                   output=f"{folder}/{name}.zarr", stages=("ingest", "extract", "dedup"),
                   sim={"label": True, "label_trials": TRIALS, "points_per_grasp": 0, **sim})
    run_local(spec, job_id=name)
    ds = open_dataset(spec.output)
    success, quality, slip = (ds[f"grasps/{k}"][:] for k in ("success", "quality", "slip"))
    return success.astype(bool), quality, slip


def main() -> dict:
    with tempfile.TemporaryDirectory() as folder:
        success, quality, slip = labelled(folder, "label-rules")
        payloads = {}
        for mass in PAYLOADS:
            rates = labelled(folder, f"payload-{mass}", load="grasp", load_mass=mass)
            payloads[str(mass)] = {"held_grasps": int(len(rates[0])), "positive_rate": rule_rates(*rates)}
    out = {"benchmark": "label_rules", "date": date.today().isoformat(), "machine": platform.machine(),
           "objects": OBJECTS, "candidates_per_object": GRASPS, "label_trials": TRIALS,
           "held_grasps": int(len(success)),
           "positive_rate": rule_rates(success, quality, slip), "grasp_load": payloads}
    path = ROOT / "benchmarks" / "results" / "label_rules.json"
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
