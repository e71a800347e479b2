"""The central commit: merge every committed part, dedup the codes globally, write the dataset.

Only this code writes the global arrays (``unique/``, ``grasps/*``), so there is one committer.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.dedup import DedupIndex
from onepiece_dist.core.similar import similar_clusters
from onepiece_dist.job.results import CommitSummary, ObjectResult
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import PartStore
from onepiece_dist.store.dataset import GroupAppender, ObjectTable, begin_dataset, finish_dataset
from onepiece_dist.store.format import CORE_GRASP_ARRAYS, GRASP_DTYPES, grasp_row_shape
from onepiece_dist.version import package_version

VIEW_PREFIX = "view_"  # per-object depth-view arrays in a part (not per grasp)
OBJECT_PREFIX = "object_"  # per-object geometry in a part (surface points, convex pieces): read by assembly
PER_OBJECT = (VIEW_PREFIX, OBJECT_PREFIX)


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
        "ingest": [{"name": r.name, "repairs": r.repairs, "shortfall": r.shortfall} for r in results
                   if r.status == "ok" and (r.repairs or r.shortfall)],
        "stats": _stats(results),
    }


def _stats(results: list[ObjectResult]) -> dict:
    ok = [r for r in results if r.status == "ok"]
    return {"objects_total": len(results), "objects_ok": len(ok), "objects_rejected": len(results) - len(ok),
            "grasps": sum(r.grasps for r in ok), "empty_crops": sum(r.empty_crops for r in ok),
            "candidates_tried": sum(r.candidates_tried for r in ok), "collisions": sum(r.collisions for r in ok),
            "settled_code_differs": sum(r.settled_code_differs for r in ok)}


def commit_dataset(spec: JobSpec, results: list[ObjectResult], parts: PartStore,
                   index: DedupIndex) -> tuple[CommitSummary, np.ndarray]:
    """Merge the parts of the ok results (in object order) and write the dataset at ``spec.output``, streaming:
    one part and one chunk per array in memory at a time.

    index : a DedupIndex that already holds every ok part's codes (the central actor's running state)
    returns : the summary, and the (U, B) uint8 codes written to ``unique/code``
    """
    out = spec.output
    ok = sorted((r for r in results if r.status == "ok"), key=lambda r: r.index)
    clusters = _similar_clusters(spec, index)
    begin_dataset(out, dataset_attrs(spec, results))
    shapes = [parts.array_shapes(r.part_key) for r in ok]
    layout = _grasp_layout(shapes, spec.code_bytes(), clusters is not None)
    every_points = keeps_every_grasp_points(spec)
    if not every_points:
        layout.pop("points", None)
    grasps = GroupAppender(out, "grasps", layout)
    views = GroupAppender(out, "views", _view_layout(shapes)) if spec.views.count else None
    cameras_before, first_row = 0, FirstRows(len(index))
    for k, result in enumerate(ok):
        arrays = {name: parts.read_array(result.part_key, name) for name in shapes[k]
                  if not name.startswith(OBJECT_PREFIX)}
        view_arrays = {name: arrays.pop(name) for name in list(arrays) if name.startswith(VIEW_PREFIX)}
        rows = _grasp_rows(arrays, k, index, clusters)
        first_row.note(rows.get("exact_index", rows["code_index"]), rows.get("points"))
        if not every_points:
            rows.pop("points", None)
        grasps.append(rows)
        if views is not None:
            views.append(_view_rows(view_arrays, k, cameras_before))
            cameras_before += len(view_arrays["view_camera"])
    grasps.close()
    if views is not None:
        views.close()
    objects = ObjectTable([r.name for r in ok], [r.content_id for r in ok], np.array([r.grasps for r in ok]))
    groups = _unique_groups(index, clusters, first_row)
    finish_dataset(out, objects, groups)
    summary = CommitSummary(grasps=int(layout["code"][0]), unique_codes=len(groups["unique"]["code"]),
                            exact_unique_codes=len(index))
    return summary, groups["unique"]["code"]


def _similar_clusters(spec: JobSpec, index: DedupIndex):
    """Hamming-radius clusters of the exact unique codes (core.similar.Clusters), or None for exact dedup."""
    if not spec.similar_radius:
        return None

    a, b, c = spec.grid_shape()
    return similar_clusters(index.unique, index.counts, a * b * c, spec.similar_radius)


def _grasp_rows(arrays: dict[str, np.ndarray], k: int, index: DedupIndex, clusters) -> dict[str, np.ndarray]:
    """One object's rows of grasps/: its part's arrays plus object and code_index (and exact_index)."""
    exact = index.lookup(arrays["code"]) if len(arrays["code"]) else np.zeros(0, np.int64)
    rows = {**arrays, "object": np.full(len(exact), k, dtype=np.int32)}
    rows["code_index"] = exact if clusters is None else clusters.cluster[exact]
    if clusters is not None:
        rows["exact_index"] = exact
    return rows


def keeps_every_grasp_points(spec: JobSpec) -> bool:
    """Whether grasps/points holds every extracted grasp's points. A job that labels on the one object and not
    every grasp needs them only for the representatives (unique/points), unless ``keep_all_points`` asks."""
    return (spec.keep_all_points or spec.sim.label or spec.budget.enabled or spec.adaptive.enabled
            or not spec.runs("label"))


def _unique_groups(index: DedupIndex, clusters, first: FirstRows) -> dict[str, dict[str, np.ndarray]]:
    """unique/ (the exact set, or one representative per cluster with exact/ beside it). ``first`` holds the
    first row in grasps/ of each exact code, a code's representative grasp (a cluster's: that of its
    representative code), and its points."""
    pick = slice(None) if clusters is None else clusters.representative
    unique = {"code": index.unique[pick], "count": index.counts if clusters is None else clusters.counts,
              "representative": first.rows[pick]}
    if first.points is not None:
        unique["points"] = first.points[pick]
    if clusters is None:
        return {"unique": unique}
    return {"unique": unique, "exact": {"code": index.unique, "count": index.counts, "cluster": clusters.cluster}}


class FirstRows:
    """The first row in grasps/ of each of ``count`` exact codes, and its points (E, P, 3) when grasps have
    points, noted as the rows stream past in order."""

    def __init__(self, count: int):
        self.rows = np.full(count, -1, dtype=np.int64)
        self.points: np.ndarray | None = None
        self.seen = 0

    def note(self, exact: np.ndarray, points: np.ndarray | None = None) -> None:
        codes, first = np.unique(exact, return_index=True)
        new = self.rows[codes] < 0
        self.rows[codes[new]] = self.seen + first[new]
        if points is not None:
            if self.points is None:
                self.points = np.zeros((len(self.rows), *points.shape[1:]), dtype=points.dtype)
            self.points[codes[new]] = points[first[new]]
        self.seen += len(exact)


def _grasp_layout(shapes: list[dict], code_bytes: int, similar: bool) -> dict[str, tuple[int, tuple, np.dtype]]:
    """Final length, row shape and dtype of every grasps/ array, from the parts' metadata (the schema's core
    arrays when no object was accepted)."""
    if shapes:
        rows = {name: shape[1:] for name, (shape, _) in shapes[0].items() if not name.startswith(PER_OBJECT)}
    else:
        rows = {name: grasp_row_shape(name, code_bytes, 0) for name in CORE_GRASP_ARRAYS}
    names = [*rows, "object", "code_index", *(["exact_index"] if similar else [])]
    total = sum(shape["code"][0][0] for shape in shapes)
    return {name: (total, rows.get(name, ()), GRASP_DTYPES[name]) for name in names}


def _view_layout(shapes: list[dict]) -> dict[str, tuple[int, tuple, np.dtype]]:
    cameras = sum(shape["view_camera"][0][0] for shape in shapes)
    points = sum(shape["view_points"][0][0] for shape in shapes)
    return {"camera": (cameras, (4, 4), np.dtype(np.float32)), "camera_object": (cameras, (), np.dtype(np.int32)),
            "points": (points, (3,), np.dtype(np.float32)), "point_camera": (points, (), np.dtype(np.int32))}


def _view_rows(view_arrays: dict[str, np.ndarray], k: int, cameras_before: int) -> dict[str, np.ndarray]:
    """views/ rows of object ``k``: its cameras and points, cameras numbered across objects."""
    cameras = view_arrays["view_camera"]
    return {"camera": cameras, "camera_object": np.full(len(cameras), k, dtype=np.int32),
            "points": view_arrays["view_points"], "point_camera": view_arrays["view_of_point"] + cameras_before}
