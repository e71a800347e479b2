"""The central commit: merge every committed part, dedup the codes globally, write the dataset.

Only this code writes the global arrays (``unique/``, ``grasps/*``), so there is one committer.
"""

from __future__ import annotations

import time
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from onepiece_dist.core.dedup import DedupIndex
from onepiece_dist.errors import JobError
from onepiece_dist.service.extract import ObjectResult
from onepiece_dist.spec import JobSpec
from onepiece_dist.store import PartStore, write_dataset
from onepiece_dist.store.dataset import ObjectTable

VIEW_PREFIX = "view_"  # per-object depth-view arrays in a part (not per grasp)


def package_version() -> str:
    try:
        return version("onepiece-dist")
    except PackageNotFoundError:
        return "0+unknown"


def dataset_attrs(spec: JobSpec, results: list[ObjectResult]) -> dict:
    a, b, c = spec.grid_shape()
    return {
        "job_spec": spec.model_dump(mode="json"),
        "gripper": spec.gripper.model_dump(mode="json"),
        "voxel": spec.voxel.model_dump(mode="json"),
        "grid_shape": [a, b, c],
        "code_bytes": spec.code_bytes(),
        "code_bit_order": "C order over (u, v, t), np.packbits bitorder='big'",
        "pose_convention": "gripper-to-object (4, 4); columns u=approach, v=closing, t=u x v; origin palm centre",
        "provenance": {"package_version": package_version(), "seed": spec.seed, "result_key": spec.result_key()},
        "rejected": [{"name": r.name, "reason": r.reason} for r in results if r.status == "rejected"],
        "stats": _stats(results),
    }


def _stats(results: list[ObjectResult]) -> dict:
    ok = [r for r in results if r.status == "ok"]
    return {"objects_total": len(results), "objects_ok": len(ok), "objects_rejected": len(results) - len(ok),
            "grasps": sum(r.grasps for r in ok), "empty_crops": sum(r.empty_crops for r in ok),
            "candidates_tried": sum(r.candidates_tried for r in ok), "collisions": sum(r.collisions for r in ok),
            "settled_code_differs": sum(r.settled_code_differs for r in ok)}


def commit_dataset(spec: JobSpec, results: list[ObjectResult], parts: PartStore, out: str,
                   index: DedupIndex | None = None) -> dict:
    """Merge the parts of the ok results (in object order) and write the dataset at ``out``.

    ``index`` : a DedupIndex that already holds every ok part's codes (the central actor's running state)
    """
    start = time.perf_counter()
    ok = sorted((r for r in results if r.status == "ok"), key=lambda r: r.index)
    fold = index is None
    index = DedupIndex(spec.code_bytes()) if fold else index
    loaded, views = [], []
    for result in ok:
        arrays = parts.read(result.part_key)
        views.append({k: arrays.pop(k) for k in list(arrays) if k.startswith(VIEW_PREFIX)})
        if fold:
            index.add(arrays["code"])
        loaded.append(arrays)
    grasps = _concatenate(loaded, spec.code_bytes())
    grasps["object"] = np.repeat(np.arange(len(ok), dtype=np.int32), [len(a["code"]) for a in loaded])
    grasps["code_index"] = index.lookup(grasps["code"]) if len(grasps["code"]) else np.zeros(0, np.int64)
    objects = ObjectTable([r.name for r in ok], [r.content_id for r in ok], np.array([r.grasps for r in ok]))
    groups = {"grasps": grasps, "unique": {"code": index.unique, "count": index.counts}}
    if spec.similar_radius:
        groups = _merge_similar(spec, groups, index)
    if spec.views.count:
        groups["views"] = _views_group(views)
    write_dataset(out, dataset_attrs(spec, results), objects, groups)
    summary = {"grasps": int(len(grasps["code"])), "unique_codes": int(len(groups["unique"]["code"])),
               "exact_unique_codes": int(len(index.unique)), "seconds": {"dedup": time.perf_counter() - start}}
    return {**summary, **assembly_stages(spec, out, summary["seconds"])} if len(index.unique) else summary


def assembly_stages(spec: JobSpec, out: str, seconds: dict | None = None) -> dict:
    """The assemble and label stages (as requested) on the committed dataset at ``out``; their wall times are
    added to ``seconds``."""
    from onepiece_dist.service.assemble import assemble_dataset
    from onepiece_dist.service.label_one import label_assembly
    from onepiece_dist.store.dataset import DatasetReader

    seconds = {} if seconds is None else seconds
    start = time.perf_counter()
    if "assemble" in spec.stages:
        assembly = assemble_dataset(spec, out)
        seconds["assemble"] = time.perf_counter() - start
    elif "label" in spec.stages:
        assembly = dict(DatasetReader(out).attrs.get("assembly", {}))
        if not assembly:
            raise JobError(f"{out}: the label stage needs an assembled object (run the assemble stage first)")
    else:
        return {}
    if "label" in spec.stages:
        start = time.perf_counter()
        assembly["labels"] = label_assembly(spec, out, spec.sim.perturbations_per_patch)
        seconds["label"] = time.perf_counter() - start
    return {"assembly": assembly}


def existing_summary(spec: JobSpec, out: str) -> dict:
    """Counts of a committed dataset, for a job that runs only later stages on it."""
    from onepiece_dist.store.dataset import DatasetReader

    reader, seconds = DatasetReader(out), {}
    return {"grasps": int(reader.array("grasps/code").shape[0]),
            "unique_codes": int(reader.array("unique/code").shape[0]), **assembly_stages(spec, out, seconds),
            "seconds": seconds}


def _merge_similar(spec: JobSpec, groups: dict, index: DedupIndex) -> dict:
    """unique/ becomes one representative per Hamming-radius cluster; the exact set moves to exact/."""
    from onepiece_dist.core.similar import similar_clusters

    a, b, c = spec.grid_shape()
    clusters = similar_clusters(index.unique, index.counts, a * b * c, spec.similar_radius)
    grasps = {**groups["grasps"], "code_index": clusters.cluster[groups["grasps"]["code_index"]],
              "exact_index": groups["grasps"]["code_index"]}
    return {"grasps": grasps, "unique": {"code": index.unique[clusters.representative], "count": clusters.counts},
            "exact": {"code": index.unique, "count": index.counts, "cluster": clusters.cluster}}


def _views_group(views: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """views/: every object's cameras and back-projected points, cameras numbered across objects."""
    if not views:
        return {"camera": np.zeros((0, 4, 4), np.float32), "camera_object": np.zeros(0, np.int32),
                "points": np.zeros((0, 3), np.float32), "point_camera": np.zeros(0, np.int32)}
    sizes = [len(v["view_camera"]) for v in views]
    first = np.cumsum([0, *sizes])[:-1]
    return {"camera": np.concatenate([v["view_camera"] for v in views]),
            "camera_object": np.repeat(np.arange(len(views), dtype=np.int32), sizes),
            "points": np.concatenate([v["view_points"] for v in views]),
            "point_camera": np.concatenate([v["view_of_point"] + f
                                            for v, f in zip(views, first, strict=True)]).astype(np.int32)}


def _concatenate(loaded: list[dict[str, np.ndarray]], code_bytes: int) -> dict[str, np.ndarray]:
    if not loaded:
        return {"pose": np.zeros((0, 4, 4), np.float32), "candidate_pose": np.zeros((0, 4, 4), np.float32),
                "width": np.zeros(0, np.float32), "code": np.zeros((0, code_bytes), np.uint8),
                "candidate_code": np.zeros((0, code_bytes), np.uint8)}
    return {name: np.concatenate([arrays[name] for arrays in loaded]) for name in sorted(loaded[0])}
