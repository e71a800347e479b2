"""One object of benchmarks/experiments/pick_view_input.py, run in the pinned simulation child (a module of its
own: run as ``__main__``, the script's functions would pickle as ``__main__.*``, which the child cannot find): each
view's camera drawn again as the labelling drew it."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

LABELS = Path(__file__).resolve().parents[2] / "data" / "pick_labels"  # the learning curve's first batch


@lru_cache(maxsize=1)
def _stored_poses() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from onepiece_dist.store.pick_labels import read_pick_labels

    labels = read_pick_labels(LABELS / "pick_labels.zarr")
    return labels.object, labels.view, labels.pose


def object_eyes(spec, ref, index: int) -> list[tuple]:
    """(object, view, eye x, y, z, matched) of each view of object ``index``: its camera drawn again, and whether
    the view's candidates hold every stored pose of its labels (none for an object without labels)."""
    from onepiece_dist.objects import load_object
    from onepiece_dist.picks.pick_labels import crop_record
    from onepiece_dist.picks.views import observe_view
    from onepiece_dist.sim.collision import load_simulated
    from onepiece_dist.sim.pick import pick_world

    objects, views, poses = _stored_poses()
    if not np.any(objects == index):
        return []
    loaded = load_object(ref, spec.object_job())
    world = pick_world(spec.gripper)
    load_simulated(world, loaded, Path(spec.output) / "collision", spec.sim.collision, spec.sim.density)
    rows = []
    for view in range(spec.views):
        seen = observe_view(spec, crop_record(spec), world, loaded.mesh, view)
        stored = poses[(objects == index) & (views == view)]
        found = np.zeros((0, 16)) if seen.proposals is None else seen.proposals.poses.reshape(-1, 16)
        matched = len(stored) > 0 and len(found) > 0 and all(
            np.abs(found - pose.reshape(16)).max(axis=1).min() == 0 for pose in stored)
        rows.append((index, view, *seen.eye, float(matched)))
    return rows
