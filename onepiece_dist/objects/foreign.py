"""Grasps made elsewhere, brought in to be labelled by our protocol (``onepiece label --grasps FILE``).

Two formats, as their public loaders read them (acronym_tools' load_grasps / load_mesh; GraspGen's JSON):
- ACRONYM ``.h5``: ``grasps/transforms`` (n, 4, 4) Franka Panda hand to object, ``grasps/qualities/flex/
  object_in_gripper`` (n,) their success, ``object/file`` (the mesh, relative to the data root: the folder above
  ``grasps/``, as ACRONYM ships ``grasps/`` and ``meshes/`` side by side) and ``object/scale``; ``gripper/type``.
- GraspGen ``.json``: ``{"object": {"file", "scale"}, "grasps": {"transforms", "object_in_gripper"}, "gripper"}``
  with the mesh relative to the object root (again the folder above ``grasps/``); ACRONYM's own ``.json`` form
  (``object``, ``object_scale``, ``transforms``, ``quality_flex_object_in_gripper``) is read as ACRONYM's.
Their transforms are the Panda hand's (``core.hand_frames``): converted to ours with the fingertips where theirs
are. A file our own export wrote keeps our poses under ``onepiece/pose``: those are used as they are. Nothing is
unpickled; every mesh path stays inside its root.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.hand_frames import from_panda
from onepiece_dist.errors import PathEscape, SourceError
from onepiece_dist.objects.paths import confined

# Gripper names in the field's files, and the preset (gripper.presets) each is.
GRIPPER_PRESETS = {"onepiece_box": None, "panda": "panda", "franka_panda": "panda", "robotiq_2f_85": "robotiq_2f85",
                   "robotiq_2f85": "robotiq_2f85", "robotiq_2f_140": "robotiq_2f140", "robotiq_2f140": "robotiq_2f140"}
ACRONYM_HELD = "grasps/qualities/flex/object_in_gripper"


@dataclass(frozen=True)
class ForeignGrasps:
    """One file's grasps: ``transforms`` (n, 4, 4) in the Panda hand's frame, ``held`` (n,) their label, the mesh
    (a file under ``root``) at ``scale``, the gripper the file names, and our own poses when our export wrote it."""

    path: Path
    format: str  # "acronym" | "graspgen"
    mesh: Path
    root: Path
    scale: float
    gripper: str
    transforms: np.ndarray
    held: np.ndarray
    own_poses: np.ndarray | None
    digest: str  # of the file's bytes: the same mesh with other grasps is another object

    def poses(self, finger_length: float) -> np.ndarray:
        """(n, 4, 4) float64 in our frame (gripper to object, origin at the palm centre) for a gripper with
        fingers ``finger_length`` long: ours when the file has them, else from the Panda hand's transforms."""
        if self.own_poses is not None:
            return self.own_poses
        return from_panda(self.transforms, finger_length)


def read_foreign_grasps(path: str | Path) -> ForeignGrasps:
    """The grasps of an ACRONYM ``.h5`` or GraspGen ``.json`` file. Raises SourceError naming the file and the
    key or path that is wrong."""
    path = Path(path)
    if not path.is_file():
        raise SourceError(f"--grasps {path}: no such file")
    data = path.read_bytes()
    digest = hashlib.blake2b(data, digest_size=16).hexdigest()
    if path.suffix.lower() == ".h5":
        fields = _acronym_fields(path)
    elif path.suffix.lower() == ".json":
        fields = _graspgen_fields(path, data)
    else:
        raise SourceError(f"--grasps {path}: expected an ACRONYM .h5 or a GraspGen .json file")
    transforms, held, mesh, scale, gripper, own, fmt = fields
    transforms = np.asarray(transforms, dtype=np.float64)
    if transforms.ndim != 3 or transforms.shape[1:] != (4, 4) or len(transforms) == 0:
        raise SourceError(f"{path}: grasp transforms must be (n >= 1, 4, 4), got {transforms.shape}")
    held = np.asarray(held).reshape(-1).astype(bool)
    if len(held) != len(transforms):
        raise SourceError(f"{path}: {len(held)} success values for {len(transforms)} grasps")
    _check_rigid(transforms, path)
    root = path.parent.parent if path.parent.name == "grasps" else path.parent
    try:
        mesh_path = confined(root / mesh, root, str(path))
    except PathEscape as err:
        raise SourceError(f"{path}: its mesh {mesh!r} lies outside {root}: {err.reason}") from None
    if not mesh_path.is_file():
        raise SourceError(f"{path}: its mesh {mesh!r} is not a file under {root} (keep the file in grasps/ beside "
                          "the meshes' folder, as ACRONYM and GraspGen ship them)")
    return ForeignGrasps(path, fmt, mesh_path, root, float(scale), gripper, transforms, held,
                         None if own is None else np.asarray(own, dtype=np.float64), digest)


def _acronym_fields(path: Path):
    try:
        import h5py
    except ModuleNotFoundError:
        raise SourceError(f"{path}: ACRONYM files are HDF5: pip install 'onepiece-dist[formats]'") from None
    try:
        with h5py.File(path, "r") as h5:
            missing = [k for k in ("grasps/transforms", ACRONYM_HELD, "object/file", "object/scale") if k not in h5]
            if missing:
                raise SourceError(f"{path}: not an ACRONYM grasp file: no {', '.join(missing)}")
            gripper = h5["gripper/type"][()] if "gripper/type" in h5 else b"panda"
            own = h5["onepiece/pose"][:] if "onepiece/pose" in h5 else None
            return (h5["grasps/transforms"][:], h5[ACRONYM_HELD][:], _text(h5["object/file"][()]),
                    float(h5["object/scale"][()]), _text(gripper), own, "acronym")
    except OSError as err:
        raise SourceError(f"{path}: cannot read it as HDF5: {err}") from None


def _graspgen_fields(path: Path, data: bytes):
    try:
        record = json.loads(data)
        if "quality_flex_object_in_gripper" in record:  # ACRONYM's own JSON form (acronym_tools reads it too)
            return (record["transforms"], record["quality_flex_object_in_gripper"], str(record["object"]),
                    float(record.get("object_scale", 1.0)), "franka_panda", None, "acronym")
        grasps, obj = record["grasps"], record["object"]
        own = record.get("onepiece", {}).get("pose")
        return (grasps["transforms"], grasps["object_in_gripper"], obj["file"], obj.get("scale", 1.0),
                str(record.get("gripper", "franka_panda")), own, "graspgen")
    except (ValueError, KeyError, TypeError) as err:
        raise SourceError(f"{path}: not a GraspGen grasp file ({type(err).__name__}: {err}); expected "
                          '{"object": {"file", "scale"}, "grasps": {"transforms", "object_in_gripper"}}') from None


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _check_rigid(transforms: np.ndarray, path: Path) -> None:
    rotations = transforms[:, :3, :3]
    error = np.abs(np.einsum("nji,njk->nik", rotations, rotations) - np.eye(3)).max(axis=(1, 2))
    bad = np.flatnonzero(~np.isfinite(transforms).all(axis=(1, 2)) | (error > 1e-4)
                         | (np.abs(transforms[:, 3] - [0, 0, 0, 1]).max(axis=1) > 1e-9))
    if len(bad):
        raise SourceError(f"{path}: {len(bad)} grasp transforms are not rigid (rotation not orthonormal, "
                          f"or not finite), first at row {int(bad[0])}")


def preset_for(gripper: str, path: Path) -> str | None:
    """The gripper preset a file's gripper name is (None: our default gripper; raises SourceError naming the
    fix)."""
    name = gripper.lower()
    if name not in GRIPPER_PRESETS:
        raise SourceError(f"{path}: gripper {gripper!r} is none of ours ({', '.join(sorted(GRIPPER_PRESETS))}); "
                          "give the gripper in the job spec (--spec) to label it with another")
    return GRIPPER_PRESETS[name]
