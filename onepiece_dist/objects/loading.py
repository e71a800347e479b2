"""Load one object reference into a validated :class:`TriangleMesh`, or reject it with a reason."""

from __future__ import annotations

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
)
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.meshio import parse_mesh_bytes
from onepiece_dist.objects.paths import confined
from onepiece_dist.objects.sources import ObjectRef
from onepiece_dist.objects.urdf import GeometryElement, parse_urdf
from onepiece_dist.spec import JobSpec


@dataclass(frozen=True)
class LoadedObject:
    ref: ObjectRef
    mesh: TriangleMesh

    @property
    def content_id(self) -> str:
        return self.mesh.content_id


def load_object(ref: ObjectRef, spec: JobSpec) -> LoadedObject:
    """Parse, validate and check that the object can meet the gripper. Raises :class:`MeshRejected`."""
    if ref.kind == "primitive":
        mesh = _primitive(*ref.primitive, name=ref.name)
    elif ref.kind == "urdf":
        mesh = _load_urdf(ref, spec.max_file_bytes)
    elif ref.kind == "mesh":
        vertices, faces = _read_mesh(Path(ref.path), Path(ref.root), ref.name, spec.max_file_bytes)
        mesh = make_mesh(vertices, faces, ref.name, ref.scale)
    else:
        raise MeshRejected(ref.name, f"unsupported file extension {Path(ref.path).suffix!r}; expected "
                                     ".obj, .stl, .ply, .glb or .urdf")
    check_graspable(mesh, spec)
    return LoadedObject(ref, mesh)


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


def _load_urdf(ref: ObjectRef, max_bytes: int) -> TriangleMesh:
    path = Path(ref.path)
    text = read_confined(path, Path(ref.root), ref.name, max_bytes).decode("utf-8", errors="replace")
    visual, collision = parse_urdf(text, confined(path, ref.root, ref.name), ref.name, Path(ref.root))
    first_error: MeshRejected | None = None
    for elements in (visual, collision):
        if not elements:
            continue
        try:
            parts = [_element_arrays(e, Path(ref.root), ref.name, max_bytes) for e in elements]  # paths confined
            return make_mesh(*merge_meshes(parts), ref.name, ref.scale)
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
                                      "(wrong units?)")
    if diagonal < spec.voxel.resolution:
        raise MeshRejected(mesh.name, f"bounding-box diagonal {diagonal:.3g} m is below one voxel "
                                      f"({spec.voxel.resolution} m)")
