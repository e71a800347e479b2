"""Which dedup key decides the label: the premise of ONE PIECE measured key by key, on unseen objects (issue 17).

    .venv/bin/python -m benchmarks.key_study [--quick] [--objects 64] [--grasps 200] [--heldout 48]
        [--heldout-grasps 200] [--load grasp] [--repeat-per-object 20] [--folder /tmp/keys]

The method labels one grasp per key (the voxel code) and lets that label stand for every grasp with the key, on
the train objects and, through the network, on unseen ones. Both experiment runs found the 10 mm code barely
decides the label (docs/paper_experiment.md, label transfer and trade-off). This asks whether another key does
better at the same redundancy, without training a network or assembling anything:

1. arm A's labels, made exactly as the paper experiment makes them (its specs and jobs: every candidate of the
   train objects labelled on its own object), and the same for unseen held-out objects;
2. every grasp's crop at its settled pose (the object's surface points in the closing region), keyed by each key
   in KEYS: occupancy codes (core.voxel) and contact keys (core.contact: the relief under each pad);
3. per key: the unique fraction of the train grasps (labels the method pays for); same-key agreement against
   random pairs on the train objects; and the lookup on held-out objects, which is the method's premise with
   perfect patches: a held-out grasp whose key some train grasp has gets the label of one of that key's train
   grasps (B's one label per key; expected over which grasp) or the key's majority label; agreement with its own
   label against the floor of a label that ignores the shape (independent, same positive rates), and coverage
   (held-out grasps whose key was seen); and B against R ranked by such lookups (budget_lookup);
4. the ceiling: A's labels against the same grasps labelled again with other perturbation draws. The share of the
   decidable label a key carries is (agreement - floor) / (ceiling - floor).

Writes benchmarks/results/NAME.json, docs/NAME.md and docs/NAME.png (NAME: key_study, --name for another).
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
from benchmarks import paper_experiment as experiment  # noqa: E402
from benchmarks.experiment_learn import pair_agreement  # noqa: E402
from benchmarks.experiment_train import spawn_context, work_folder  # noqa: E402
from onepiece_dist.core.contact import ContactKeySpec, contact_keys  # noqa: E402
from onepiece_dist.core.dedup import unique_codes  # noqa: E402
from onepiece_dist.study.lookup import (  # noqa: E402
    budget_lookup,
    decided_share,
    lookup_transfer,
)

# (name, kind, parameters): occupancy at a resolution (m); contact keys at a pad cell, relief step and levels,
# opening step (m); "both" concatenates the 10 mm occupancy code and a contact key.
KEYS: tuple[tuple[str, str, dict], ...] = (
    ("occupancy 10 mm", "occupancy", {"resolution": 0.01}),
    ("occupancy 5 mm", "occupancy", {"resolution": 0.005}),
    ("contact 20 mm cells, 4 mm relief", "contact", {"cell": 0.02, "step": 0.004, "levels": 3, "width_step": 0.01}),
    ("contact 20 mm cells, 2 mm relief", "contact", {"cell": 0.02, "step": 0.002, "levels": 4, "width_step": 0.005}),
    ("contact 10 mm cells, 4 mm relief", "contact", {"cell": 0.01, "step": 0.004, "levels": 3, "width_step": 0.01}),
    ("contact 10 mm cells, 2 mm relief", "contact", {"cell": 0.01, "step": 0.002, "levels": 4, "width_step": 0.005}),
    ("occupancy 10 mm + contact 20 mm, 4 mm", "both",
     {"resolution": 0.01, "cell": 0.02, "step": 0.004, "levels": 3, "width_step": 0.01}),
)
REDUNDANCY_KEYS = ("occupancy 10 mm", "contact 10 mm cells, 4 mm relief")  # the experiment's code, the best contact key
QUICK = {"objects": 4, "grasps": 16, "heldout": 3, "heldout_grasps": 16, "label_trials": 2, "repeat_per_object": 4,
         "redundancy": "4,8"}


@dataclass(frozen=True)
class Crops:
    """Every grasp's crop at its settled pose: points (q, 3) float64 gripper frame, rows (q,) int64 grasp of each
    point; per grasp (n,): success bool, quality float64, object int64."""

    points: np.ndarray
    rows: np.ndarray
    success: np.ndarray
    quality: np.ndarray
    object: np.ndarray

    @property
    def count(self) -> int:
        return len(self.success)


def occupancy_of(crops: Crops, grid: tuple[int, int, int], resolution: float) -> np.ndarray:
    """Packed occupancy codes of the crops at ``resolution``: (n, B) uint8 (core.voxel's layout)."""
    from onepiece_dist.study.keys import Crops as KeyCrops
    from onepiece_dist.study.keys import occupancy

    region = tuple(n * resolution for n in grid)
    return occupancy(KeyCrops(crops.points, crops.rows, crops.count), region, resolution)


def keys_of(crops: Crops, kind: str, params: dict, region: tuple[float, float, float]) -> np.ndarray:
    """(n, K) uint8: each crop's key of this kind (KEYS)."""
    if kind == "occupancy":
        r = params["resolution"]
        return occupancy_of(crops, tuple(int(round(x / r)) for x in region), r)
    if kind == "contact":
        return contact_keys(crops.rows, crops.points, crops.count, ContactKeySpec(region, **params))
    if kind == "both":
        contact = {k: v for k, v in params.items() if k != "resolution"}
        return np.concatenate([keys_of(crops, "occupancy", {"resolution": params["resolution"]}, region),
                               keys_of(crops, "contact", contact, region)], axis=1)
    raise ValueError(f"unknown key kind {kind!r}")


def first_per_object(crops: Crops, count: int) -> Crops:
    """The crops of each object's first ``count`` grasps (dataset order: candidate order within an object), grasps
    renumbered in order: as if each object had been given fewer candidates."""
    keep = experiment._rank_within_object(crops.object) < count
    new_row = np.cumsum(keep) - 1
    points = keep[crops.rows]
    return Crops(crops.points[points], new_row[crops.rows[points]], crops.success[keep], crops.quality[keep],
                 crops.object[keep])


def redundancy_rows(train: Crops, heldout: Crops, region: tuple[float, float, float], counts: list[int],
                    seed: int) -> list[dict]:
    """B against R (:func:`budget_lookup`) for each key of REDUNDANCY_KEYS, with each train object cut to its
    first n grasps, for each n in ``counts``: how the gap moves as the grasps per object, and so the redundancy,
    grow."""
    rows = []
    for name, kind, params in (key for key in KEYS if key[0] in REDUNDANCY_KEYS):
        held_keys = keys_of(heldout, kind, params, region)
        for n in counts:
            cut = first_per_object(train, n)
            train_keys = keys_of(cut, kind, params, region)
            rows.append({"key": name, "grasps_per_object": n, "grasps": cut.count,
                         "unique_fraction": round(len(unique_codes(train_keys).unique) / max(cut.count, 1), 4),
                         "budget": budget_lookup(train_keys, cut.success, held_keys, heldout.success, seed)})
    return rows


def key_rows(train: Crops, heldout: Crops, region: tuple[float, float, float], ceiling: float | None,
             seed: int) -> list[dict]:
    """One row of measures per key of KEYS."""
    rows = []
    for name, kind, params in KEYS:
        train_keys, held_keys = keys_of(train, kind, params, region), keys_of(heldout, kind, params, region)
        exact = unique_codes(train_keys)
        lookup = lookup_transfer(train_keys, train.success, held_keys, heldout.success)
        rows.append({"key": name, "kind": kind, "params": params, "key_bytes": int(train_keys.shape[1]),
                     "unique": int(len(exact.unique)),
                     "unique_fraction": round(len(exact.unique) / max(train.count, 1), 4),
                     "pairs": pair_agreement(train.success.astype(np.float64), train.quality, exact.inverse, seed),
                     "lookup": lookup, "budget": budget_lookup(train_keys, train.success, held_keys,
                                                               heldout.success, seed),
                     "decided_share_one_label": decided_share(lookup["one_label"], ceiling),
                     "decided_share_majority": decided_share(lookup["majority"], ceiling)})
    return rows


def settled_crops(dataset: Path, spec) -> Crops:
    """Every grasp of a labelled dataset cropped at its settled pose (study.keys.settled_crops), with its labels."""
    from onepiece_dist.store import open_dataset
    from onepiece_dist.study.keys import settled_crops as crops_of

    ds, crops = open_dataset(str(dataset)), crops_of(str(dataset), spec)
    return Crops(crops.points, crops.rows, ds["grasps/success"].astype(bool), ds["grasps/quality"].astype(np.float64),
                 ds["grasps/object"].astype(np.int64))


def generate(args, folder: Path) -> dict:
    """Arm A's labelled train grasps and the held-out grasps, as the paper experiment makes them (two
    single-process jobs at once; a job whose dataset ``folder`` already holds from the same spec is reused)."""
    specs = experiment.generation_specs(experiment_args(args), folder)
    with ProcessPoolExecutor(2, mp_context=spawn_context()) as pool:
        a = pool.submit(experiment.run_job, "A", specs["A"].model_dump_json())
        heldout = pool.submit(experiment.run_job, "heldout", specs["heldout"].model_dump_json())
        return {"A": a.result(), "heldout": heldout.result(), "specs": specs}


def experiment_args(args) -> argparse.Namespace:
    """The paper experiment's arguments for this study's sizes and label: every other choice is the experiment's."""
    return experiment.parse_args([
        "--objects", str(args.objects), "--grasps", str(args.grasps), "--heldout", str(args.heldout),
        "--heldout-grasps", str(args.heldout_grasps), "--label-trials", str(args.label_trials),
        "--load", args.load, "--load-mass", str(args.load_mass), "--seed", str(args.seed)])


def run_study(args, folder: Path) -> dict:
    from benchmarks.experiment_b_variants import label_repeatability

    gen = generate(args, folder)
    spec = gen["specs"]["A"]
    train = settled_crops(folder / "A.zarr", spec)
    heldout = settled_crops(folder / "heldout.zarr", gen["specs"]["heldout"])
    ceiling = label_repeatability(folder, args.repeat_per_object, args.seed)
    region = (spec.gripper.closing_depth, spec.gripper.closing_width, spec.gripper.closing_height)
    return {"jobs": {k: gen[k] for k in ("A", "heldout")}, "ceiling": ceiling,
            "train": _summary(train), "heldout": _summary(heldout),
            "keys": key_rows(train, heldout, region, ceiling["agreement"], args.seed),
            "redundancy": redundancy_rows(train, heldout, region, [int(n) for n in args.redundancy.split(",")],
                                          args.seed)}


def _summary(crops: Crops) -> dict:
    return {"grasps": crops.count, "objects": int(len(np.unique(crops.object))),
            "positive_rate": round(float(crops.success.mean()), 4) if crops.count else None,
            "mean_points": round(len(crops.rows) / max(crops.count, 1), 1)}


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in (("objects", 64), ("grasps", 200), ("heldout", 48), ("heldout-grasps", 200),
                          ("label-trials", 4), ("repeat-per-object", 20), ("seed", 0)):
        parser.add_argument(f"--{name}", type=int, default=default)
    parser.add_argument("--load", choices=("object", "grasp"), default="grasp",
                        help="what the label trials lift and shake: the object, or a payload at the grasp centre")
    parser.add_argument("--load-mass", type=float, default=0.5, help="the payload (kg) with --load grasp")
    parser.add_argument("--redundancy", default="25,50,100,200",
                        help="B against R with each train object cut to its first n labelled grasps, for these n")
    parser.add_argument("--quick", action="store_true", help="a few objects: a smoke test of the whole script")
    parser.add_argument("--folder", type=Path, default=None, help="work folder, kept (default: a temporary one)")
    parser.add_argument("--out", type=Path, default=HERE.parent, help="where results/ JSON and docs/ pages go")
    parser.add_argument("--name", default="key_study", help="file name of the results, the page and its plot")
    args = parser.parse_args(argv)
    if args.quick:
        for key, value in QUICK.items():
            setattr(args, key, value)
    return args


def command_line(args) -> str:
    sizes = " ".join(f"--{k.replace('_', '-')} {getattr(args, k)}" for k in
                     ("objects", "grasps", "heldout", "heldout_grasps", "repeat_per_object"))
    return f"python -m benchmarks.key_study {sizes} --load {args.load}"


def main(argv=None) -> dict:
    from onepiece_dist.study.key_study_page import plot_keys, write_page

    args = parse_args(argv)
    start = time.perf_counter()
    with work_folder(args.folder, "onepiece-keys-") as folder:
        out = run_study(args, folder)
    out.update({"name": args.name, "command": command_line(args), "quick": args.quick, "load": args.load,
                "load_mass": args.load_mass, "label_trials": args.label_trials, "date": date.today().isoformat(),
                "machine": f"{platform.machine()}, {_cores()} cores",
                "wall_seconds": round(time.perf_counter() - start, 1)})
    (args.out / "benchmarks" / "results").mkdir(parents=True, exist_ok=True)
    (args.out / "docs").mkdir(parents=True, exist_ok=True)
    (args.out / "benchmarks" / "results" / f"{args.name}.json").write_text(json.dumps(out, indent=2) + "\n")
    plot_keys(out, args.out / "docs" / f"{args.name}.png")
    write_page(out, args.out / "docs" / f"{args.name}.md")
    return out


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


if __name__ == "__main__":
    main()
