"""What would lift B to R? The experiment's B arms trained again with patch weights or other inputs.

    .venv/bin/python -m benchmarks.experiment_b_variants --folder /tmp/exp-full [--radii 0,2]
        [--variants as_trained,sqrt_weights,count_weights,representatives,source_labels] [--repeat-per-object 40]

B labels each shape once, on its patch of the one object, and trains on the one object's crops with uniform
batches over its patches. Two reasons it could trail R (a random subset of candidates labelled on their own
objects) that are not its labels: a uniform batch treats a shape met once like one met a thousand times, while R's
subset follows how often shapes occur; and the one object's crops may differ from real objects' crops. This trains
the B arms of the committed paper experiment (benchmarks/results/paper_experiment.json; its kept work folder
``--folder`` holds the datasets) again:

  as_trained       B as the experiment trained it (a check of the rerun);
  sqrt_weights     each patch's loss weighed by the square root of its code's grasp count;
  count_weights    ... by the count itself (``unique/count``, the train stage's ``weight_by_count``);
  representatives  B's labels on the representatives' own crops (``unique/points``: each code's representative
                   grasp cropped on its source object), not the one object's;
  source_labels    the representatives' own crops with the labels arm A gave the representative grasps on their
                   source objects: B as it would be if every patch's label were its representative's (a perfect
                   patch), the bound of anything that makes the one object's trials more faithful.

And one measure of the labels themselves: a seeded sample of A's grasps (``--repeat-per-object`` per object)
labelled again on their own objects with other perturbation draws (the label transfer's stream,
``service/transfer.py``). How often A agrees with itself bounds how often any label can agree with A's.

Everything else as the experiment trained B: network, steps, batch, seeds, the learning rate each arm's validation
split chose, the checkpoint its validation split picks; held-out: the experiment's.
Writes benchmarks/results/experiment_b_variants.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
from benchmarks.experiment_learn import TrainJob, arm_summary  # noqa: E402
from benchmarks.experiment_train import spawn_context, train_all  # noqa: E402

VARIANTS = {"as_trained": "none", "sqrt_weights": "sqrt", "count_weights": "count", "representatives": "none",
            "source_labels": "none"}


def representatives_dataset(source: Path, out: Path) -> Path:
    """A dataset whose ``grasps`` are B's labelled patches with their representatives' own crops as points:
    points ``unique/points[patch]``, success the patch's label, object the patch (validation splits by patch)."""
    import zarr

    src = zarr.open_group(str(source), mode="r")
    patch = src["assembled/grasps/patch"][:].astype(np.int64)
    return _crops_dataset(source, out, patch, src["assembled/grasps/success"][:])


def source_labels_dataset(source: Path, a_path: Path, out: Path) -> Path:
    """As :func:`representatives_dataset`, but each row's success is the label arm A (``a_path``) gave its patch's
    representative grasp on its source object (found by object name and candidate pose). Rows whose representative
    A did not label are left out."""
    from onepiece_dist.store import open_dataset
    from onepiece_dist.study.premise import match_rows

    b, a = open_dataset(str(source)), open_dataset(str(a_path))
    patch = b["assembled/grasps/patch"].astype(np.int64)
    in_a = match_rows(b, a)[b["unique/representative"].astype(np.int64)[patch]]
    keep = in_a >= 0
    return _crops_dataset(source, out, patch[keep], a["grasps/success"][in_a[keep]])


def _crops_dataset(source: Path, out: Path, patch: np.ndarray, success: np.ndarray) -> Path:
    """Write ``out``: rows (n,) of ``patch`` with points ``unique/points[patch]`` of the B dataset ``source``, the
    given ``success`` (n,) and the patch as object; ``source``'s attributes but its one object's reports."""
    import zarr

    src, group = zarr.open_group(str(source), mode="r"), zarr.open_group(str(out), mode="w")
    group.attrs.update({k: v for k, v in src.attrs.asdict().items() if k not in ("assembly", "labels")})
    points = src["unique/points"]
    group.create_array("grasps/points", data=points[:][patch], chunks=(512, *points.shape[1:]))
    group.create_array("grasps/success", data=success)
    group.create_array("grasps/object", data=patch.astype(np.int32))
    return out


def label_repeatability(folder: Path, per_object: int, seed: int) -> dict:
    """A's labels against the same grasps labelled again on their own objects with other perturbation draws:
    ``per_object`` seeded grasps of each train object of A (``folder/A.zarr``, its spec from its status file)."""
    from onepiece_dist.service.status import JobStatus
    from onepiece_dist.service.transfer import label_on_sources
    from onepiece_dist.spec import JobSpec
    from onepiece_dist.store import PartStore, open_dataset

    spec = JobSpec.model_validate(JobStatus.model_validate_json((folder / "A.zarr.status.json").read_text()).spec)
    reader = open_dataset(spec.output)
    objects = reader["grasps/object"].astype(np.int64)
    rng = np.random.default_rng([seed, 23])
    rows = np.sort(np.concatenate([rng.permutation(np.flatnonzero(objects == o))[:per_object]
                                   for o in np.unique(objects)]))
    again, quality = label_on_sources(spec, reader, PartStore(spec.parts_folder()), rows)
    return repeat_agreement(reader["grasps/success"][rows].astype(bool), again.astype(bool),
                            reader["grasps/quality"][rows].astype(np.float64), quality)


def repeat_agreement(first: np.ndarray, again: np.ndarray, first_quality: np.ndarray,
                     again_quality: np.ndarray) -> dict:
    """Agreement of two labellings (n,) bool of the same grasps, their quality correlation, and the agreement two
    independent labellings with the same positive rates would have (the floor)."""
    p, q = float(first.mean()), float(again.mean())
    spread = first_quality.std() > 0 and again_quality.std() > 0
    return {"grasps": len(first), "agreement": round(float(np.mean(first == again)), 4),
            "quality_correlation": round(float(np.corrcoef(first_quality, again_quality)[0, 1]), 4) if spread else None,
            "positive_rate": round(p, 4), "positive_rate_again": round(q, 4),
            "independent_floor": round(p * q + (1 - p) * (1 - q), 4)}


def variant_jobs(experiment: dict, folder: Path, radii: list[int], variants: list[str]) -> list[TrainJob]:
    """Every (radius, variant, seed) training run, as the experiment trained B at that radius."""
    args, search = experiment["args"], experiment["learning_rate_search"]
    jobs = []
    for radius in radii:
        for variant in variants:
            path, group = folder / f"B-settled-{radius}.zarr", "assembled/grasps"
            if variant == "representatives":
                path, group = representatives_dataset(path, folder / f"B-representatives-{radius}.zarr"), "grasps"
            if variant == "source_labels":
                path, group = source_labels_dataset(path, folder / "A.zarr",
                                                    folder / f"B-source-labels-{radius}.zarr"), "grasps"
            jobs += [TrainJob(f"B r{radius} {variant}", seed, str(path), group, None,
                              str(folder / "heldout.zarr"),
                              args["model"], args["steps"], args["batch_size"], search[f"B r{radius}"]["chosen"], 0.2,
                              patch_weighting=VARIANTS[variant]) for seed in range(args["seeds"])]
    return jobs


def summary_rows(experiment: dict, jobs: list[TrainJob], runs: list[dict], labels: np.ndarray,
                 groups: np.ndarray) -> list[dict]:
    """Per (radius, variant): held-out top-1 and AP over the seeds, beside the experiment's B and R of that
    radius."""
    arms = {row["arm"]: row["heldout"] for row in experiment["arms"]}
    rows = []
    for name in dict.fromkeys(job.arm for job in jobs):
        _, radius, variant = name.split()
        held = arm_summary([run for job, run in zip(jobs, runs, strict=True) if job.arm == name], labels, groups)
        rows.append({"radius": int(radius[1:]), "variant": variant,
                     "top1": round(held["top1"]["mean"], 4), "top1_ci95": held["top1"]["ci95"],
                     "ap": round(held["ap"]["mean"], 4), "ap_std": round(held["ap"]["std"], 4),
                     "ap_ci95": held["ap"]["ci95"], "seeds": len(held["seeds"]),
                     "experiment_b_ap": round(arms[f"B {radius}"]["ap"]["mean"], 4),
                     "experiment_r_ap": round(arms[f"R {radius}"]["ap"]["mean"], 4),
                     "experiment_r_top1": round(arms[f"R {radius}"]["top1"]["mean"], 4)})
    return rows


def transfer_agreement(experiment: dict) -> dict:
    """Per radius, how often the experiment's B patch labels agree with their representatives' and with every
    grasp of their code (arm A's labels; docs/paper_experiment.md, Label transfer)."""
    kinds = ("patch_vs_representative", "patch_vs_every_grasp")
    return {str(t["radius"]): {k: t[k]["success_agreement"] for k in kinds} for t in experiment["label_transfer"]}


def dataset_counts(folder: Path, experiment: dict, radii: list[int]) -> dict:
    """[here, the experiment's] labelled grasps of each B dataset in ``folder`` and held-out candidates: equal
    counts say these are the experiment's datasets; others, that they were made again from its specs (on a machine
    with another CPU a few grasps in 10,000 differ: docs/assembly.md)."""
    from onepiece_dist.store import open_dataset

    arms = {row["arm"]: row for row in experiment["arms"]}
    counts = {f"B r{r}": [int(open_dataset(str(folder / f"B-settled-{r}.zarr")).array("assembled/grasps/success")
                              .shape[0]), arms[f"B r{r}"]["labelled_grasps"]] for r in radii}
    held = open_dataset(str(folder / "heldout.zarr")).array("grasps/success").shape[0]
    return {**counts, "heldout": [int(held), experiment["heldout"]["grasps"]]}


def main(argv=None) -> dict:
    from concurrent.futures import ProcessPoolExecutor

    from onepiece_dist.store import open_dataset

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, required=True, help="the experiment's kept work folder")
    parser.add_argument("--radii", default="0,2")
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--repeat-per-object", type=int, default=40,
                        help="A's grasps per train object labelled again (0: no repeatability measure)")
    args = parser.parse_args(argv)
    variants = args.variants.split(",")
    if unknown := sorted(set(variants) - set(VARIANTS)):
        parser.error(f"--variants: {unknown} unknown; choose from {', '.join(VARIANTS)}")
    experiment = json.loads((HERE / "results" / "paper_experiment.json").read_text())
    radii = [int(r) for r in args.radii.split(",")]
    jobs = variant_jobs(experiment, args.folder, radii, variants)
    with ProcessPoolExecutor(2, mp_context=spawn_context()) as pool:
        runs = train_all(jobs, args.folder / "trained", pool)
    heldout = open_dataset(str(args.folder / "heldout.zarr"))
    labels, groups = heldout["grasps/success"].astype(np.float64), heldout["grasps/object"].astype(np.int64)
    out = {"benchmark": "experiment_b_variants", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores", "experiment": experiment["command"].strip(),
           "experiment_date": experiment["date"], "model": experiment["args"]["model"],
           "steps": experiment["args"]["steps"], "train_seconds": round(sum(r["train_seconds"] for r in runs), 1),
           "heldout_random_choice": round(experiment["heldout"]["random_choice"], 4),
           "rows": summary_rows(experiment, jobs, runs, labels, groups),
           "dataset_counts": dataset_counts(args.folder, experiment, radii),
           "label_transfer": transfer_agreement(experiment),
           "label_repeatability": (label_repeatability(args.folder, args.repeat_per_object, experiment["args"]["seed"])
                                   if args.repeat_per_object else None),
           "command": "python -m benchmarks.experiment_b_variants " + " ".join(sys.argv[1:] if argv is None else argv)}
    (HERE / "results" / "experiment_b_variants.json").write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out["rows"], indent=2))
    return out


if __name__ == "__main__":
    main()
