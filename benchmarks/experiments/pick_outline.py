"""What the object is outside the fingers (issue 55, what the network sees): a crop holds only the points between
the fingers and the context only the object's centre; the picks lost are mugs dropped when shaken (the body
hanging off the rim), bowls and flat packages. ``context_balanced_outline`` also reads the observed object's
outline seen from the grasp (64 farthest-point samples of its cloud in the gripper frame: core.cloud.outline),
through a PointNet of its own. The top-down trial's labels, each view seen again to cut the outlines (the same
seeded settle, camera and cloud: each row's stored context must come back to the bit); fitted seed for seed
against that trial's networks, both planning with the top-down grasps in the pool. Kept by the trials' paired
rule on the household set (docs/picks.md), the unseen set reported beside.

    .venv/bin/python -m benchmarks.experiments.pick_outline [--seeds 0,1,2,3]

Results: benchmarks/results/pick_outline.json (points kept; a run again fits only what is missing).
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import get_context

import numpy as np

from benchmarks.experiments.pick_curve import ROOT
from benchmarks.experiments.pick_on_policy import second_batch
from benchmarks.experiments.pick_top_down import fit_seeds, top_down_batch

DESIGN = "context_balanced_outline"


def _object_outlines(args) -> tuple[int, tuple[np.ndarray, np.ndarray], float]:
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.pick_labels import outlines_again
    from onepiece_dist.specs.plan import PickLabelSpec

    spec_json, index, view, pose, context = args
    spec = PickLabelSpec.model_validate(spec_json)
    start = time.perf_counter()
    found = outlines_again(spec, resolve_source(spec.objects)[index], view, pose, context)
    return index, found, time.perf_counter() - start


def outlined(labels, processes: int = 2):
    """``labels`` (one store's) with each row's outline, cut from its view seen again; the rows of views that
    settled elsewhere when seen again are left out (their count in the store's attribute ``views_not_again``);
    kept beside the store (``<output>_outline``) and read back from there once made."""
    import zarr

    from onepiece_dist.store.pick_labels import read_pick_labels, write_pick_labels

    path = ROOT / (labels.attrs["spec"]["output"] + "_outline") / "pick_labels.zarr"
    if path.exists():
        return read_pick_labels(path)
    ok = [o for o in labels.attrs["objects"] if o["status"] == "ok" and o["rows"]]
    rows = {o["index"]: np.flatnonzero(labels.object == o["index"]) for o in ok}
    tasks = [(labels.attrs["spec"], i, labels.view[r], labels.pose[r], labels.context[r]) for i, r in rows.items()]
    start, found = time.perf_counter(), {}
    with get_context("spawn").Pool(processes) as pool:
        for index, outline, seconds in pool.imap_unordered(_object_outlines, tasks):
            found[index] = (outline, seconds)
    objects = [_with_outline(labels, o, rows.get(o["index"]), found.get(o["index"], (None,))[0])
               for o in labels.attrs["objects"]]
    seen_again = sum(seconds for _, seconds in found.values())
    write_pick_labels(path, objects, labels.attrs["spec"], labels.attrs["core_seconds"] + seen_again,
                      labels.attrs["wall_seconds"] + time.perf_counter() - start)
    names = {o["index"]: o["name"] for o in ok}
    missed = [f"{names[i]} view {v}" for i, ((_, same), _) in sorted(found.items())
              for v in np.unique(labels.view[rows[i]][~same])]
    zarr.open_group(str(path), mode="r+").attrs["views_not_again"] = missed
    return read_pick_labels(path)


def _with_outline(labels, listed: dict, rows: np.ndarray | None, outlines: tuple | None):
    """One object's labelled rows whose views came back, each with its outline (an object without rows as
    listed)."""
    from onepiece_dist.store.pick_labels import LabelledObject

    if rows is None:  # rejected, or no rows
        return LabelledObject(listed["index"], listed["name"], listed["status"], listed["reason"], listed["seconds"])
    outline, same = outlines
    columns = {name: getattr(labels, name)[rows[same]] for name in
               ("points", "context", "space", "success", "held", "failure", "view", "pose")}
    return LabelledObject(listed["index"], listed["name"], listed["status"], listed["reason"], listed["seconds"],
                          **columns, outline=outline[same])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2,3")
    args = parser.parse_args()
    first, second = outlined(top_down_batch()), outlined(second_batch(None))
    joined = first.joined(second)
    missed = [*first.attrs.get("views_not_again", []), *second.attrs.get("views_not_again", [])]
    fit_seeds(joined, DESIGN, args.seeds, DESIGN, "outline", "pick_outline",
              {"design": DESIGN, "labels": len(joined), "views_not_again": missed})


if __name__ == "__main__":
    main()
