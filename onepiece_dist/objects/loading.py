"""Load one object reference into a validated :class:`TriangleMesh`, or reject it with a reason."""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.frames import transform_points
from onepiece_dist.core.mesh import (
    TriangleMesh,
    box_mesh,
    cylinder_mesh,
    make_mesh,
    merge_meshes,
    sphere_mesh,
    validate_arrays,
    wound_outwards,
)
from onepiece_dist.core.repair import boundary_edges, closed_volume, connected_pieces, weld
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.meshio import parse_mesh_bytes
from onepiece_dist.objects.paths import confined
from onepiece_dist.objects.shapes import SHAPE_KINDS, shape_mesh
from onepiece_dist.objects.sources import ObjectRef
from onepiece_dist.objects.urdf import GeometryElement, parse_urdf
from onepiece_dist.specs.job import JobSpec


@dataclass(frozen=True)
class LoadedObject:
    """A loaded object and what was repaired on the way (e.g. 'faces wound inwards: flipped')."""

    ref: ObjectRef
    mesh: TriangleMesh
    repairs: tuple[str, ...] = ()

    @property
    def content_id(self) -> str:
        """The mesh's content id, or with a manifest's mass, density or friction or a grasp file's grasps, a hash
        of it and them: the same mesh with other physics or other grasps is another object (its own parts)."""
        physics = (self.ref.mass, self.ref.density, self.ref.friction)
        if physics == (None, None, None) and not self.ref.grasps_digest:
            return self.mesh.content_id
        given = f":{self.ref.grasps_digest}" if self.ref.grasps_digest else ""  # its grasps are another object's
        text = f"{self.mesh.content_id}:{physics!r}{given}".encode()
        return hashlib.blake2b(text, digest_size=16).hexdigest()

    def density(self, default: float, volume: float) -> float:
        """kg/m^3 of the simulated body: the manifest's density, or its mass over ``volume``, else ``default``."""
        if self.ref.mass is not None:
            return self.ref.mass / max(volume, 1e-12)
        return self.ref.density if self.ref.density is not None else default

    @property
    def friction(self) -> float:
        """The object's own friction coefficient (1: the pads' alone)."""
        return 1.0 if self.ref.friction is None else self.ref.friction


def load_object(ref: ObjectRef, spec: JobSpec) -> LoadedObject:
    """Parse, validate, repair what is safe to repair (said in ``repairs``) and check that the object can meet
    the gripper. A job's ``units`` and ``scale`` apply to files it names (not to pybullet_data's sets). Raises
    :class:`MeshRejected`. A folder's objects.yaml (objects.manifest) may name its units and each object's scale."""
    scale = ref.scale * (1.0 if ref.units_known else spec.unit_scale())
    if ref.kind == "primitive":
        return _checked(LoadedObject(ref, _primitive(*ref.primitive, name=ref.name)), spec)
    if ref.kind == "urdf":
        vertices, faces = _load_urdf(ref, spec.max_file_bytes)
    elif ref.kind == "mesh":
        vertices, faces = _read_mesh(Path(ref.path), Path(ref.root), ref.name, spec.max_file_bytes)
    else:
        raise MeshRejected(ref.name, f"unsupported file extension {Path(ref.path).suffix!r}; expected "
                                     ".obj, .stl, .ply, .glb or .urdf")
    validate_arrays(np.asarray(vertices, dtype=np.float64), np.asarray(faces), ref.name)
    vertices, faces, repairs = repaired(np.asarray(vertices, dtype=np.float64), np.asarray(faces))
    return _checked(LoadedObject(ref, make_mesh(vertices, faces, ref.name, scale), repairs), spec)


def repaired(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Vertices welded, faces wound outwards, and what was done or found, in words (core.repair). Disconnected
    pieces stay parts of one rigid object; an open surface keeps its holes (the gripper crops what is there)
    and its mass comes from the volume with the holes capped (core.mesh.enclosed_volume)."""
    notes = []
    vertices, faces, merged = weld(vertices, faces)
    if merged:
        notes.append(f"{merged} vertices split at UV seams or duplicated: welded ({len(vertices)} remain)")
    faces, flipped = wound_outwards(vertices, faces)
    if flipped:
        notes.append("faces wound inwards (negative enclosed volume): flipped")
    pieces = connected_pieces(faces, len(vertices))
    if pieces > 1:
        notes.append(f"{pieces} disconnected pieces: kept as parts of one rigid object")
    _, holes = closed_volume(vertices, faces)
    if holes:
        notes.append(f"open surface ({len(boundary_edges(faces))} rim edges, {holes} holes): mass from the "
                     "volume with its holes capped")
    return vertices, faces, tuple(notes)


def _checked(loaded: LoadedObject, spec: JobSpec) -> LoadedObject:
    check_graspable(loaded.mesh, spec)
    return loaded


def read_confined(path: Path, root: Path, source: str, max_bytes: int) -> bytes:
    """Bytes of a file that lies inside ``root`` and is at most ``max_bytes`` long."""
    real = confined(path, root, source)
    try:
        size = os.stat(real).st_size
        if size > max_bytes:
            raise MeshRejected(source, f"file is {size} bytes, over the cap of {max_bytes} (max_file_bytes)")
        with open(real, "rb") as handle:
            return handle.read(max_bytes + 1)
    except OSError as err:
        raise MeshRejected(source, f"cannot read {path}: {err.strerror}") from None


def _read_mesh(path: Path, root: Path, source: str, max_bytes: int) -> tuple[np.ndarray, np.ndarray]:
    data = read_confined(path, root, source, max_bytes)
    return parse_mesh_bytes(data, path.suffix.lower(), source)


def _load_urdf(ref: ObjectRef, max_bytes: int) -> tuple[np.ndarray, np.ndarray]:
    path = Path(ref.path)
    text = read_confined(path, Path(ref.root), ref.name, max_bytes).decode("utf-8", errors="replace")
    visual, collision = parse_urdf(text, confined(path, ref.root, ref.name), ref.name, Path(ref.root))
    first_error: MeshRejected | None = None
    for elements in (visual, collision):
        if not elements:
            continue
        try:
            parts = [_element_arrays(e, Path(ref.root), ref.name, max_bytes) for e in elements]  # paths confined
            return merge_meshes(parts)
        except MeshRejected as err:
            first_error = first_error or err
    raise first_error or MeshRejected(ref.name, "URDF link has no visual or collision geometry")


def _element_arrays(element: GeometryElement, folder: Path, source: str,
                    max_bytes: int) -> tuple[np.ndarray, np.ndarray]:
    if element.kind == "mesh":
        vertices, faces = _read_mesh(element.path, folder, source, max_bytes)
        vertices = vertices * np.asarray(element.scale)
    else:
        prim = _primitive(element.kind, element.dims, name=source)
        vertices, faces = prim.vertices, prim.faces
    return transform_points(vertices, element.origin), faces


def _primitive(kind: str, dims: tuple, name: str) -> TriangleMesh:
    if kind in SHAPE_KINDS:
        return shape_mesh(kind, dims, name)
    if kind == "box":
        return box_mesh(tuple(dims), name=name)
    if kind == "cylinder":
        return cylinder_mesh(dims[0], dims[1], name=name)
    return sphere_mesh(dims[0], name=name)


def check_graspable(mesh: TriangleMesh, spec: JobSpec) -> None:
    """Reject objects far too large (wrong units) or smaller than one voxel. Whether the gripper fits
    anywhere is decided by the candidate sampler (no contact pair narrower than the opening: rejected)."""
    diagonal = float(np.linalg.norm(mesh.extents))
    if diagonal > spec.sampler.max_object_extent:
        raise MeshRejected(mesh.name, f"bounding-box diagonal {diagonal:.3g} m exceeds "
                                      f"sampler.max_object_extent={spec.sampler.max_object_extent} m "
                                      f"(wrong units?{_fitting_units(diagonal, spec)})")
    if diagonal < spec.voxel.resolution:
        raise MeshRejected(mesh.name, f"bounding-box diagonal {diagonal:.3g} m is below one voxel "
                                      f"({spec.voxel.resolution} m)")


UNIT_FACTORS = {"cm": 0.01, "mm": 0.001}
HAND_SIZED = (0.01, 0.5)  # m: the bounding-box diagonals of objects a parallel gripper picks


def _fitting_units(diagonal: float, spec: JobSpec) -> str:
    """' the file looks like centimetres: ...' when a unit's scale brings ``diagonal`` (m, as read at the job's
    units) to a hand-held size; '' when none does."""
    for unit, factor in UNIT_FACTORS.items():
        fitted = diagonal * factor
        if HAND_SIZED[0] <= fitted <= min(HAND_SIZED[1], spec.sampler.max_object_extent):
            return (f" the file looks like {unit}: set units: {unit} (--units {unit}; scale {factor:g}), which "
                    f"gives a {fitted:.3g} m diagonal")
    return ""
