"""Mesh file parsing from bytes already read (so parsers never open other files: no mtllib, no external
buffers). OBJ is parsed here; STL, PLY and GLB through trimesh."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from onepiece_dist.errors import MeshRejected


def parse_mesh_bytes(data: bytes, suffix: str, source: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) float64 and triangle faces (m, 3) int64 of a mesh file's bytes (not yet validated)."""
    if not data.strip():
        raise MeshRejected(source, "file is empty")
    if suffix == ".obj":
        return parse_obj(data, source)
    if suffix in (".stl", ".ply", ".glb"):
        return _parse_with_trimesh(data, suffix[1:], source)
    raise MeshRejected(source, f"unsupported file extension {suffix!r}; expected .obj, .stl, .ply, .glb or .urdf")


def parse_obj(data: bytes, source: str) -> tuple[np.ndarray, np.ndarray]:
    """Wavefront OBJ: 'v' and 'f' records (polygons fanned into triangles, negative indices allowed)."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise MeshRejected(source, "not a text OBJ file (bytes are not UTF-8)") from None
    vertices, faces = [], []
    for lineno, line in enumerate(text.splitlines(), 1):
        fields = line.split()
        if not fields or fields[0] not in ("v", "f"):
            continue
        try:
            if fields[0] == "v":
                vertices.append([float(x) for x in fields[1:4]])
            else:
                faces.extend(_fan([_obj_index(f, len(vertices)) for f in fields[1:]]))
        except (ValueError, IndexError):
            raise MeshRejected(source, f"malformed OBJ record at line {lineno}: {line[:60]!r}") from None
    if not vertices or not faces:
        raise MeshRejected(source, f"OBJ has {len(vertices)} vertices and {len(faces)} faces; need both")
    return np.array(vertices, dtype=np.float64).reshape(-1, 3), np.array(faces, dtype=np.int64)


def _obj_index(field: str, nverts: int) -> int:
    i = int(field.split("/")[0])
    return i - 1 if i > 0 else nverts + i


def _fan(polygon: list[int]) -> list[list[int]]:
    if len(polygon) < 3:
        raise ValueError("a face needs three vertices")
    return [[polygon[0], polygon[k], polygon[k + 1]] for k in range(1, len(polygon) - 1)]


def _parse_with_trimesh(data: bytes, file_type: str, source: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=file_type, process=False)
        if isinstance(loaded, trimesh.Scene):
            return _scene_to_arrays(loaded)
        vertices, faces = np.asarray(loaded.vertices), np.asarray(loaded.faces)
    except MeshRejected:
        raise
    except Exception as err:  # parsers raise anything on hostile bytes
        raise MeshRejected(source, f"cannot parse as {file_type.upper()}: {type(err).__name__}: {err}"[:300]) from None
    return vertices, faces


def _scene_to_arrays(scene) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate a scene's triangle meshes in the scene frame (geometry only, no materials)."""
    vertices, faces, offset = [], [], 0
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        if not hasattr(geometry, "faces"):
            continue
        v = np.asarray(geometry.vertices, dtype=np.float64)
        vertices.append(v @ transform[:3, :3].T + transform[:3, 3])
        faces.append(np.asarray(geometry.faces, dtype=np.int64) + offset)
        offset += len(v)
    if not vertices:
        raise ValueError("scene holds no triangle mesh")
    return np.vstack(vertices), np.vstack(faces)


def write_obj(vertices: np.ndarray, faces: np.ndarray, path: Path) -> None:
    """A plain OBJ (vertices and faces only), written atomically."""
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    _write_atomic(path, "\n".join(lines) + "\n")


def write_ply(vertices: np.ndarray, faces: np.ndarray, path: Path) -> None:
    """An ASCII PLY of a triangle mesh, written atomically."""
    header = (f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty float x\nproperty float y\n"
              f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = [f"{x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices] + [f"3 {a} {b} {c}" for a, b, c in faces]
    _write_atomic(path, header + "\n".join(body) + "\n")


def _write_atomic(path: Path, text: str) -> None:
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
