"""Headless pictures of the assembled object (pybullet's TinyRenderer), optionally some of its labelled grasps
with the gripper drawn (the Panda hand's meshes or the simulated model's boxes), and a gallery of codes with their
three projections, written as one PNG (no imaging library needed)."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np

from onepiece_dist.core.classifier import projections
from onepiece_dist.core.voxel import unpack_codes
from onepiece_dist.errors import MissingAssembly
from onepiece_dist.store.dataset import DatasetReader

VIEW = 320
COLOURS = {0: (0.90, 0.35, 0.25, 1), 1: (0.30, 0.65, 0.30, 1), 2: (0.25, 0.45, 0.90, 1), 3: (0.75, 0.75, 0.75, 1)}
GREY = (0.7, 0.7, 0.7, 1)
GALLERY_CODES, CELL = 8, 10


def render_assembly(path: str | os.PathLike, out: str | os.PathLike, grasps: int = 0,
                    hand: str = "panda") -> Path:
    """Three views of the one object, ``grasps`` of its labelled grasps (green held, red dropped) and a gallery
    of its first codes; returns the PNG path."""
    reader = DatasetReader(path)
    if not reader.has("assembled/vertices"):
        raise MissingAssembly(f"{path}: no assembled object (run the assemble stage)")
    mesh = reader["assembled/vertices"], reader["assembled/faces"], reader["assembled/face_group"]
    rows = [render_views(*mesh)]
    if grasps > 0:
        rows.append(render_grasps(reader, mesh, grasps, hand))
    rows.append(code_gallery(reader["unique/code"][:GALLERY_CODES], tuple(reader.attrs["grid_shape"])))
    width = max(row.shape[1] for row in rows)
    canvas = np.full((sum(row.shape[0] for row in rows), width, 3), 255, dtype=np.uint8)
    top = 0
    for row in rows:
        canvas[top:top + row.shape[0], :row.shape[1]] = row
        top += row.shape[0]
    write_png(canvas, Path(out))
    return Path(out)


def render_grasps(reader: DatasetReader, mesh: tuple, count: int, hand: str) -> np.ndarray:
    """(VIEW, count VIEW, 3) uint8: the first ``count`` labelled grasps of the one object, each seen along the
    gripper's t axis with the gripper at its settled pose and final opening."""
    import pybullet as pb

    from onepiece_dist.sim.hand import add_hand
    from onepiece_dist.specs.job import GripperSpec

    if not reader.has("assembled/grasps/pose"):
        raise MissingAssembly(f"{reader.path}: no labelled grasps on the one object (run the label stage)")
    gripper = GripperSpec.model_validate(reader.attrs["job_spec"]["gripper"])
    poses = reader["assembled/grasps/pose"][:count].astype(np.float64)
    widths, success = reader["assembled/grasps/width"][:count], reader["assembled/grasps/success"][:count]
    vertices, faces, _ = mesh
    images = []
    client = pb.connect(pb.DIRECT)
    try:
        _add_mesh(pb, client, vertices, faces, np.zeros(len(faces), int), {0: GREY})  # once; hands come and go
        for pose, width, held in zip(poses, widths, success, strict=True):
            colour = (0.3, 0.8, 0.3, 1) if held else (0.9, 0.3, 0.3, 1)
            bodies = add_hand(pb, client, pose, float(width), gripper, hand, colour)
            centre = pose[:3, :3] @ [gripper.closing_depth / 2, 0, 0] + pose[:3, 3]
            look = pose[:3, :3] @ [-0.35, 0.2, 1.0]
            images.append(_snapshot(pb, client, centre, 0.2, look, up=pose[:3, 0]))
            for body in bodies:
                pb.removeBody(body, physicsClientId=client)
    finally:
        pb.disconnect(client)
    return np.hstack(images) if images else np.full((VIEW, VIEW, 3), 255, dtype=np.uint8)


def render_views(vertices: np.ndarray, faces: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """(VIEW, 3 VIEW, 3) uint8: the mesh from three directions, faces coloured by group."""
    import pybullet as pb

    client = pb.connect(pb.DIRECT)
    try:
        _add_mesh(pb, client, vertices, faces, groups)
        centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
        radius = float(np.linalg.norm(np.ptp(vertices, axis=0))) * 1.1
        images = [_snapshot(pb, client, centre, radius, direction)
                  for direction in ([1, 0.6, 0.5], [0.4, 1, 0.7], [0.6, 0.5, 1])]
    finally:
        pb.disconnect(client)
    return np.hstack(images)


def _add_mesh(pb, client: int, vertices: np.ndarray, faces: np.ndarray, groups: np.ndarray,
              colours: dict = COLOURS) -> None:
    """The mesh as visual-only bodies, one per face group in its colour."""
    for group, colour in colours.items():
        tri = faces[groups == group]
        if len(tri):
            used, inverse = np.unique(tri, return_inverse=True)
            shape = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices[used].tolist(),
                                         indices=inverse.astype(int).ravel().tolist(), rgbaColor=colour,
                                         physicsClientId=client)
            pb.createMultiBody(baseVisualShapeIndex=shape, physicsClientId=client)


def _snapshot(pb, client: int, centre: np.ndarray, radius: float, direction, up=(0, 0, 1)) -> np.ndarray:
    direction = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    view = pb.computeViewMatrix((centre + direction * radius * 1.6).tolist(), centre.tolist(), list(up))
    proj = pb.computeProjectionMatrixFOV(45, 1.0, 0.01, radius * 5)
    _, _, rgba, _, _ = pb.getCameraImage(VIEW, VIEW, view, proj, renderer=pb.ER_TINY_RENDERER,
                                         physicsClientId=client)
    return np.reshape(rgba, (VIEW, VIEW, 4))[:, :, :3].astype(np.uint8)


def code_gallery(codes: np.ndarray, grid_shape: tuple[int, int, int]) -> np.ndarray:
    """One row per code: its (u, v), (u, t) and (v, t) projections as black-on-white cells."""
    rows = []
    for occupancy in unpack_codes(codes, grid_shape):
        tiles = [_tile(p[0]) for p in projections(occupancy[None])]
        height = max(t.shape[0] for t in tiles)
        row = [np.pad(t, ((0, height - t.shape[0]), (0, CELL)), constant_values=255) for t in tiles]
        rows.append(np.pad(np.hstack(row), ((0, CELL), (CELL, 0)), constant_values=255))
    if not rows:
        return np.full((CELL, CELL, 3), 255, dtype=np.uint8)
    width = max(r.shape[1] for r in rows)
    grey = np.vstack([np.pad(r, ((0, 0), (0, width - r.shape[1])), constant_values=255) for r in rows])
    return np.repeat(grey[:, :, None], 3, axis=2)


def _tile(projection: np.ndarray) -> np.ndarray:
    cells = np.where(projection, 30, 235).astype(np.uint8)
    tile = np.kron(cells, np.ones((CELL, CELL), dtype=np.uint8))
    tile[::CELL, :] = 180
    tile[:, ::CELL] = 180
    return tile


def write_png(image: np.ndarray, path: Path) -> None:
    """(H, W, 3) uint8 RGB -> PNG file."""
    height, width, _ = image.shape
    raw = b"".join(b"\x00" + image[row].tobytes() for row in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(png)
