"""Pick labels on disk (``pick_labels.zarr``, docs/picks.md): candidates of settled, seen training objects executed
by the pick protocol, one row per execution, in object then view order. Readable with zarr and numpy alone:

    points (n, P, 3) float16  the crop in the gripper frame (m)
    context (n, 6) float32    gravity and the object-centre offset in the gripper frame (core.grasp_context)
    space (n, G) float16      the hand's swept space as the camera saw it (core.cloud.swept_space; G = 0 in stores
                              made before it)
    outline (n, K, 3) float16 the observed object's points seen from the grasp (core.cloud.outline; K = 0 in
                              stores made before it)
    success (n,) bool         every trial held
    held (n,) int8            trials that held
    failure (n,) int8         index into the root attribute ``failure_codes`` ('' for a pick)
    object (n,) int32, view (n,) int16, pose (n, 4, 4) float64 (gripper to world)
    picks (n,) float32        the share of the row's executions that picked (picks.top_draws: fresh draws of a
                              network's best grasps; absent from stores of one execution a row: its success)

Root attributes: ``spec`` (the PickLabelSpec), ``objects`` (name, status, reason, rows, seconds per object),
``failure_codes``, ``core_seconds`` and ``wall_seconds``. One writer: the process that ran the labelling.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from onepiece_dist.errors import StoreError
from onepiece_dist.store.codecs import write_array

FAILURE_CODES = ("", "start_collision", "no_contact", "slipped_lifting", "dropped_shaking")
COLUMNS = ("points", "context", "space", "outline", "success", "held", "failure", "view", "pose", "picks")


def _empty(shape: tuple[int, ...], dtype) -> np.ndarray:
    return np.zeros(shape, dtype)


@dataclass(frozen=True)
class LabelledObject:
    """One object's labels (its rows of the columns), or ``status`` 'rejected' with ``reason``."""

    index: int
    name: str
    status: str
    reason: str = ""
    seconds: float = 0.0
    points: np.ndarray = field(default_factory=lambda: _empty((0, 1, 3), np.float16))
    context: np.ndarray = field(default_factory=lambda: _empty((0, 6), np.float32))
    space: np.ndarray = field(default_factory=lambda: _empty((0, 0), np.float16))
    outline: np.ndarray = field(default_factory=lambda: _empty((0, 0, 3), np.float16))
    success: np.ndarray = field(default_factory=lambda: _empty((0,), bool))
    held: np.ndarray = field(default_factory=lambda: _empty((0,), np.int8))
    failure: np.ndarray = field(default_factory=lambda: _empty((0,), np.int8))
    view: np.ndarray = field(default_factory=lambda: _empty((0,), np.int16))
    pose: np.ndarray = field(default_factory=lambda: _empty((0, 4, 4), np.float64))
    picks: np.ndarray | None = None  # None: one execution a row (its success)

    def __post_init__(self):
        if self.picks is None:
            object.__setattr__(self, "picks", self.success.astype(np.float32))

    @classmethod
    def rejected(cls, index: int, name: str, reason: str, seconds: float = 0.0) -> LabelledObject:
        return cls(index, name, "rejected", reason, seconds)

    @property
    def rows(self) -> int:
        return len(self.success)


@dataclass(frozen=True)
class PickLabels:
    """Every row of a ``pick_labels.zarr``, read back."""

    points: np.ndarray
    context: np.ndarray
    space: np.ndarray
    outline: np.ndarray
    success: np.ndarray
    held: np.ndarray
    failure: np.ndarray
    object: np.ndarray
    view: np.ndarray
    pose: np.ndarray
    picks: np.ndarray
    attrs: dict

    def __len__(self) -> int:
        return len(self.success)

    def joined(self, other: PickLabels) -> PickLabels:
        """These rows then ``other``'s (its objects numbered after these); attributes: these, with both stores'
        objects, core-seconds and specs."""
        offset = int(self.object.max()) + 1 if len(self) else 0
        attrs = {**self.attrs, "objects": [*self.attrs["objects"], *({**o, "index": o["index"] + offset}
                                                                     for o in other.attrs["objects"])],
                 "core_seconds": self.attrs["core_seconds"] + other.attrs["core_seconds"],
                 "specs": [*self.attrs.get("specs", [self.attrs["spec"]]), other.attrs["spec"]]}
        both = {name: np.concatenate([getattr(self, name), getattr(other, name)]) for name in COLUMNS}
        return PickLabels(**both, object=np.concatenate([self.object, other.object + offset]), attrs=attrs)

    def subset(self, rows: np.ndarray) -> PickLabels:
        return PickLabels(**{name: getattr(self, name)[rows] for name in (*COLUMNS, "object")}, attrs=self.attrs)


def write_pick_labels(path: str | os.PathLike, objects: list[LabelledObject], spec: dict, core_seconds: float,
                      wall_seconds: float) -> None:
    """Write every object's rows (object order) and the attributes; replaces what was at ``path``."""
    import zarr

    done = sorted((o for o in objects if o.status == "ok" and o.rows), key=lambda o: o.index)
    group = zarr.open_group(str(path), mode="w")
    for name in COLUMNS:
        parts = [getattr(o, name) for o in done]
        write_array(group, name, np.concatenate(parts) if parts else getattr(LabelledObject(0, "", ""), name))
    rows = [np.full(o.rows, o.index, np.int32) for o in done]
    write_array(group, "object", np.concatenate(rows) if rows else np.zeros(0, np.int32))
    group.attrs.update({
        "spec": spec, "failure_codes": list(FAILURE_CODES), "core_seconds": round(core_seconds, 1),
        "wall_seconds": round(wall_seconds, 1),
        "objects": [{"index": o.index, "name": o.name, "status": o.status, "reason": o.reason, "rows": o.rows,
                     "seconds": round(o.seconds, 2)} for o in sorted(objects, key=lambda o: o.index)]})


def read_pick_labels(path: str | os.PathLike) -> PickLabels:
    """Every row of the pick labels at ``path``; :class:`StoreError` naming the path when it is none."""
    import zarr

    try:
        group = zarr.open_group(str(path), mode="r")
        optional = {"space": (0,), "outline": (0, 3)}  # absent from stores made before them: empty per row
        arrays = {name: np.asarray(group[name][...]) for name in (*COLUMNS, "object")
                  if name not in optional and name != "picks"}
        for name, shape in optional.items():
            arrays[name] = (np.asarray(group[name][...]) if name in group else
                            np.zeros((len(arrays["success"]), *shape), np.float16))
        arrays["picks"] = (np.asarray(group["picks"][...]) if "picks" in group else
                           arrays["success"].astype(np.float32))
    except (FileNotFoundError, KeyError) as err:
        raise StoreError(f"{path}: not a pick-labels store ({err}): make one with run_pick_labels") from None
    return PickLabels(**arrays, attrs=dict(group.attrs))
