"""The field's formats: ACRONYM's HDF5 file per object and GraspGen's JSON file per object with its split lists
(docs/dataset_format.md, Other formats).

Both describe a grasp by the Franka Panda hand's transform (``core.hand_frames``), a mesh file relative to a mesh
root, and a success mask. The objects' meshes are not in the dataset: they are loaded again from the job's object
source and matched by content id, then written under ``DIR/meshes/`` in the object frame the grasps use (scale 1).
The one object exports the same way, its mesh ``assembled/vertices`` and its labelled grasps. Names that are not
safe file names are mapped to safe ones; ``DIR/index.json`` lists every object with its files. Nothing is written
outside ``DIR``.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from onepiece_dist.core.hand_frames import to_panda
from onepiece_dist.errors import MeshRejected, StoreError
from onepiece_dist.objects import load_object
from onepiece_dist.objects.meshio import write_obj
from onepiece_dist.objects.paths import confined
from onepiece_dist.objects.sources import resolve_source
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import DatasetReader

ONE_OBJECT = "one_object"  # the name the assembled one object exports under
OWN_ARRAYS = ("width", "quality", "slip", "shift", "code", "candidate_pose", "patch")  # under our own group


class ExportRefused(StoreError):
    """The dataset lacks what the format needs (labels, meshes): the message says what and how to get it."""


@dataclass(frozen=True)
class GraspSet:
    """One object's labelled grasps: ``poses`` (n, 4, 4) float64 ours (gripper-to-object), ``held`` (n,) bool,
    its mesh in the same object frame, and our own per-grasp arrays (``OWN_ARRAYS`` that the dataset holds)."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    poses: np.ndarray
    held: np.ndarray
    own: dict[str, np.ndarray] = field(default_factory=dict)


def labelled_grasp_sets(path: str | os.PathLike) -> tuple[JobSpec, list[GraspSet]]:
    """Every object's labelled grasps (``grasps/`` with ``sim.label``) and the one object's
    (``assembled/grasps/``), with their meshes. Refused with the reason when there are no labels."""
    reader = DatasetReader(path)
    spec = JobSpec.model_validate(reader.attrs["job_spec"])
    sets = []
    if reader.has("grasps/success"):
        sets += _source_sets(reader, spec)
    if reader.has("assembled/grasps/success"):
        sets.append(_one_object_set(reader))
    if not sets:
        raise ExportRefused(f"{path}: no labelled grasps (neither grasps/success nor assembled/grasps/success): "
                            "these formats need each grasp's outcome; extract with sim.label: true, or run the "
                            "assemble and label stages")
    return spec, sets


def _rows(reader: DatasetReader, group: str, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """Rows start to stop of the group's pose, success and our own arrays (only those rows are read)."""
    def read(name: str) -> np.ndarray:
        return reader.array(f"{group}/{name}")[start:stop]

    own = {name: read(name) for name in OWN_ARRAYS if reader.has(f"{group}/{name}")}
    return read("pose").astype(np.float64), read("success").astype(bool), own


def _source_sets(reader: DatasetReader, spec: JobSpec) -> list[GraspSet]:
    names, ids = reader.object_names, [bytes(row).hex() for row in reader["objects/id"]]
    meshes = source_meshes(spec, names, ids)
    start, count = reader["objects/grasp_start"], reader["objects/grasp_count"]
    sets = []
    for k, name in enumerate(names):
        poses, held, own = _rows(reader, "grasps", int(start[k]), int(start[k] + count[k]))
        sets.append(GraspSet(name, *meshes[ids[k]], poses, held, own))
    return sets


def _one_object_set(reader: DatasetReader) -> GraspSet:
    poses, held, own = _rows(reader, "assembled/grasps", 0, reader.array("assembled/grasps/success").shape[0])
    return GraspSet(ONE_OBJECT, reader["assembled/vertices"].astype(np.float64),
                    reader["assembled/faces"].astype(np.int64), poses, held, own)


def source_meshes(spec: JobSpec, names: list[str], ids: list[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{content id: (vertices, faces)} of the dataset's objects, loaded again from the job's object source (the
    mesh each grasp's pose refers to). Refused, naming the object, when the source no longer gives it."""
    wanted = dict(zip(names, ids, strict=True))
    found = {}
    for ref in resolve_source(spec.objects):
        if ref.name in wanted and wanted[ref.name] not in found:
            try:
                mesh = load_object(ref, spec).mesh
            except MeshRejected:
                continue
            found[mesh.content_id] = (np.asarray(mesh.vertices), np.asarray(mesh.faces))
    missing = [name for name, cid in wanted.items() if cid not in found]
    if missing:
        raise ExportRefused(f"the meshes of {missing[:5]}{' ...' if len(missing) > 5 else ''} are not found: the "
                            f"job's object source {spec.objects!r} no longer gives them with the geometry the "
                            "grasps were made on (run the export where the job ran, or restore the files)")
    return found


def safe_names(names: list[str]) -> list[str]:
    """A file stem per name: letters, digits, '.', '_' and '-' only, no leading dot, no mesh file extension (a
    'mug.obj' object's mesh is meshes/mug.obj, not mug.obj.obj), at most 80 characters, each unique (a clash gets
    '-2', '-3', ...)."""
    out, taken = [], set()
    for name in names:
        bare = re.sub(r"\.(obj|stl|ply|glb|urdf)$", "", name, flags=re.IGNORECASE)
        stem = re.sub(r"[^A-Za-z0-9._-]", "_", bare).lstrip(".")[:80] or "object"
        candidate, n = stem, 1
        while candidate.lower() in taken:
            n += 1
            candidate = f"{stem}-{n}"
        taken.add(candidate.lower())
        out.append(candidate)
    return out


class ExportFolder:
    """The export's folder: every path written is checked to lie inside it."""

    def __init__(self, out: str | os.PathLike):
        self.root = Path(out)
        self.root.mkdir(parents=True, exist_ok=True)
        self.written: list[Path] = []

    def path(self, relative: str) -> Path:
        target = confined(self.root / relative, self.root, f"export file {relative!r}")
        target.parent.mkdir(parents=True, exist_ok=True)
        self.written.append(target)
        return target

    def write_mesh(self, stem: str, grasp_set: GraspSet) -> str:
        """The object's mesh as ``meshes/STEM.obj``; returns that path relative to the folder (the mesh root)."""
        relative = f"meshes/{stem}.obj"
        write_obj(grasp_set.vertices, grasp_set.faces, self.path(relative))
        return relative

    def write_index(self, fmt: str, dataset: str | os.PathLike, rows: list[dict], **extra) -> Path:
        index = self.path("index.json")
        index.write_text(json.dumps({"format": fmt, "dataset": str(dataset), "frame": FRAME_NOTE, **extra,
                                     "objects": rows}, indent=1) + "\n")
        return index


FRAME_NOTE = ("transforms: Franka Panda hand to object (origin at the hand's base, z approach, x closing, y = z x "
              "x), fingertips where ours are: T_panda = T_ours @ [[0,0,1,L-0.11217],[1,0,0,0],[0,1,0,0],[0,0,0,1]] "
              "with L our finger length; onepiece/pose keeps ours (columns u, v, t; origin at the palm centre)")


def export_acronym(path: str | os.PathLike, out: str | os.PathLike) -> list[Path]:
    """One ACRONYM HDF5 file per object (and the one object): object/file (mesh relative to ``out``),
    object/scale, grasps/transforms (Panda frame), grasps/qualities/flex/object_in_gripper, and our own arrays
    under onepiece/. Returns the files written."""
    try:
        import h5py
    except ModuleNotFoundError:
        raise ExportRefused("ACRONYM's format is HDF5: install h5py (pip install 'onepiece-dist[formats]')") from None
    spec, sets = labelled_grasp_sets(path)
    folder, rows = ExportFolder(out), []
    for stem, grasp_set in zip(safe_names([s.name for s in sets]), sets, strict=True):
        mesh = folder.write_mesh(stem, grasp_set)
        with h5py.File(folder.path(f"grasps/{stem}.h5"), "w") as h5:
            h5.create_dataset("object/file", data=mesh, dtype=h5py.string_dtype())
            h5.create_dataset("object/scale", data=1.0)
            h5.create_dataset("object/density", data=spec.sim.density)
            h5.create_dataset("object/friction", data=spec.gripper.friction)
            h5.create_dataset("gripper/type", data=spec.gripper.name, dtype=h5py.string_dtype())
            h5.create_dataset("grasps/transforms", data=to_panda(grasp_set.poses, spec.gripper.finger_length))
            h5.create_dataset("grasps/qualities/flex/object_in_gripper", data=grasp_set.held.astype(np.int64))
            h5.create_dataset("onepiece/pose", data=grasp_set.poses)
            for name, values in grasp_set.own.items():
                h5.create_dataset(f"onepiece/{name}", data=values)
        rows.append(_index_row(grasp_set, stem, mesh, f"grasps/{stem}.h5"))
    folder.write_index("acronym", path, rows, mesh_root=".")
    return folder.written


def export_graspgen(path: str | os.PathLike, out: str | os.PathLike, valid_fraction: float = 0.2,
                    valid_objects: tuple[str, ...] = ()) -> list[Path]:
    """GraspGen's layout: ``grasps/STEM.json`` per object ({"object": {"file", "scale"}, "grasps":
    {"transforms", "object_in_gripper"}}, Panda frame, a boolean mask) and ``splits/train.txt`` /
    ``splits/valid.txt`` naming the mesh files (relative to ``out``, the object root). The validation objects are
    ``valid_objects`` by name, else a seeded ``valid_fraction`` of them (the job's seed); the one object, when
    present, is always a training object."""
    spec, sets = labelled_grasp_sets(path)
    folder, rows = ExportFolder(out), []
    valid = validation_names([s.name for s in sets if s.name != ONE_OBJECT], valid_fraction, valid_objects, spec.seed)
    splits: dict[str, list[str]] = {"train": [], "valid": []}
    for stem, grasp_set in zip(safe_names([s.name for s in sets]), sets, strict=True):
        mesh = folder.write_mesh(stem, grasp_set)
        record = {"object": {"file": mesh, "scale": 1.0}, "gripper": spec.gripper.name,
                  "grasps": {"transforms": to_panda(grasp_set.poses, spec.gripper.finger_length).tolist(),
                             "object_in_gripper": grasp_set.held.tolist()},
                  "onepiece": {"pose": grasp_set.poses.tolist(),
                               **{n: v.tolist() for n, v in grasp_set.own.items() if n in ("width", "quality")}}}
        folder.path(f"grasps/{stem}.json").write_text(json.dumps(record))
        splits["valid" if grasp_set.name in valid else "train"].append(mesh)
        rows.append(_index_row(grasp_set, stem, mesh, f"grasps/{stem}.json"))
    for split, meshes in splits.items():
        folder.path(f"splits/{split}.txt").write_text("".join(f"{m}\n" for m in meshes))
    folder.write_index("graspgen", path, rows, object_root=".", valid=sorted(valid))
    return folder.written


def validation_names(names: list[str], fraction: float, chosen: tuple[str, ...], seed: int) -> set[str]:
    """The validation objects: ``chosen`` (each must be an object of the dataset), else a seeded ``fraction``
    (at least one object when there are two or more)."""
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        raise ExportRefused(f"--valid-objects: {unknown} are not objects of the dataset (it has {names[:8]} ...)")
    if chosen:
        return set(chosen)
    if not 0 <= fraction < 1:
        raise ExportRefused(f"--valid-fraction {fraction}: expected at least 0 and below 1")
    count = 0 if len(names) < 2 or fraction == 0 else max(1, round(fraction * len(names)))
    order = np.random.default_rng(seed).permutation(len(names))
    return {names[k] for k in order[:count]}


def _index_row(grasp_set: GraspSet, stem: str, mesh: str, grasps: str) -> dict:
    return {"name": grasp_set.name, "file": grasps, "mesh": mesh, "grasps": int(len(grasp_set.held)),
            "held": int(grasp_set.held.sum())}
