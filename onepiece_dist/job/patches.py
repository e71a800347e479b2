"""Patches: for each unique code, the real geometry its representative grasp held (docs/assembly.md).

A patch is cut from the source object of the code's representative grasp at the settled pose, in the gripper
frame: the object's collision pieces (the convex decomposition the simulation used) clipped to the patch box,
and the object's dense surface points inside the same box. The patch box is the closing region grown by
``PATCH_MARGIN`` across the fingers' height and width and by ``PATCH_SUPPORT`` beyond the fingertips (the material
behind what the pads hold). Clipped convex pieces stay convex, so a patch is a few convex pieces, exact with
respect to what was simulated. The source geometry comes from each object's extraction part (``object_*`` arrays).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.assembly_layout import patch_box
from onepiece_dist.core.clip import clip_to_box
from onepiece_dist.core.frames import rotate_points
from onepiece_dist.core.ragged import row_offsets, split_rows, stack_rows
from onepiece_dist.errors import StoreError
from onepiece_dist.job.results import ObjectPartMeta, part_key
from onepiece_dist.specs.job import GripperSpec, JobSpec
from onepiece_dist.store import DatasetReader, PartStore

SURFACE, PIECE_VERTICES, PIECE_SIZES = "object_surface", "object_piece_vertices", "object_piece_sizes"


@dataclass(frozen=True)
class Patches:
    """U patches in their own (gripper) frames. representative (U,) int64 row in grasps/; pieces: per patch a list
    of (k, 3) convex-piece points (float32 values, as stored); points: per patch (m, 3) float64 surface points in
    the patch box (float32 values, what the store's form gives back); source_volume (U,) float64 volume of the
    source object (m^3, its mass rule: docs/assembly.md); sources: the surface points (S_i, 3) of each source
    object a patch is cut from (as stored: :func:`as_stored`), once each; source_object (U,) int64 which of them;
    source_pose (U, 4, 4) float32 the representative's settled pose on it. The store keeps the sources, not the
    points: a patch's points are its source's points inside the patch box at its pose (:func:`cut_points`),
    derived wherever they are read."""

    representative: np.ndarray
    pieces: list[list[np.ndarray]]
    points: list[np.ndarray]
    source_volume: np.ndarray
    sources: list[np.ndarray]
    source_object: np.ndarray
    source_pose: np.ndarray

    def __len__(self) -> int:
        return len(self.representative)

    def arrays(self) -> dict[str, np.ndarray]:
        """The flat arrays stored under ``assembled/`` (docs/dataset_format.md)."""
        piece_list = [piece for pieces in self.pieces for piece in pieces]
        return {"representative": self.representative.astype(np.int64),
                "patch_piece_count": np.array([len(p) for p in self.pieces], dtype=np.int64),
                "piece_vertex_count": np.array([len(p) for p in piece_list], dtype=np.int64),
                "piece_vertices": stack_rows(piece_list, np.float32),
                "source_volume": self.source_volume.astype(np.float64),
                "source_point_count": np.array([len(p) for p in self.sources], dtype=np.int64),
                **quantized_sources(self.sources),
                "source_object": self.source_object.astype(np.int64),
                "source_pose": self.source_pose.astype(np.float32)}


QUANTUM_LEVELS = 65535  # a source's points are stored as uint16 steps over its bounding box (each axis)


def quantize(surface: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(S, 3) float64 points as (S, 3) uint16 steps, and the box (lower (3,), step (3,)) float64 that decodes them:
    about 5 micrometres a step on a 30 cm object, 6 bytes a point."""
    lower, upper = surface.min(axis=0), surface.max(axis=0)
    step = np.maximum(upper - lower, 1e-9) / QUANTUM_LEVELS
    return np.rint((surface - lower) / step).astype(np.uint16), lower, step


def dequantize(steps: np.ndarray, lower: np.ndarray, step: np.ndarray) -> np.ndarray:
    return lower + steps.astype(np.float64) * step


def as_stored(surface: np.ndarray) -> np.ndarray:
    """What the store gives back for a source's points: the patches are cut from this, here and after a read."""
    return dequantize(*quantize(np.asarray(surface, dtype=np.float64)))


def quantized_sources(sources: list[np.ndarray]) -> dict[str, np.ndarray]:
    coded = [quantize(surface) for surface in sources]
    return {"source_points": np.concatenate([c[0] for c in coded]) if coded else np.zeros((0, 3), np.uint16),
            "source_box": np.array([[c[1], c[2]] for c in coded]).reshape(-1, 2, 3)}


def cut_points(surface: np.ndarray, pose: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(m, 3) float64 holding float32 values: the object-frame ``surface`` (S, 3) float64 seen in the gripper frame
    of ``pose`` (4, 4), inside the patch box [lower, upper]. Rounded to float32 as format 1 stored them, so the one
    object's codes, labels and pins do not move."""
    pose = np.asarray(pose, dtype=np.float64)
    local = rotate_points(surface - pose[:3, 3], pose[:3, :3])
    return local[np.all((local >= lower) & (local <= upper), axis=1)].astype(np.float32).astype(np.float64)


def read_patches(reader: DatasetReader, start: int = 0, stop: int | None = None) -> Patches:
    """Patches ``start`` to ``stop`` (default: all) of the one object, reading only their rows of the flat
    arrays and the surfaces of their own source objects: a label shard holds its own patches, not the whole
    object."""
    piece_count = reader["assembled/patch_piece_count"].astype(np.int64)
    vertex_count = reader["assembled/piece_vertex_count"].astype(np.int64)
    stop = len(piece_count) if stop is None else stop
    first_piece, first_vertex = row_offsets(piece_count), row_offsets(vertex_count)
    p0, p1 = first_piece[start], first_piece[stop]

    def rows(name: str, begin: int, end: int) -> np.ndarray:
        return reader.array(f"assembled/{name}")[int(begin):int(end)]

    pieces = split_rows(rows("piece_vertices", first_vertex[p0], first_vertex[p1]), vertex_count[p0:p1])
    starts = first_piece[start:stop + 1] - p0
    source_object = rows("source_object", start, stop).astype(np.int64)
    source_pose = rows("source_pose", start, stop)
    point_starts = row_offsets(reader["assembled/source_point_count"].astype(np.int64))
    boxes = reader["assembled/source_box"].astype(np.float64)
    sources = {int(o): dequantize(rows("source_points", point_starts[o], point_starts[o + 1]), *boxes[o])
               for o in np.unique(source_object)}
    ordered = sorted(sources)
    local = np.searchsorted(ordered, source_object)
    return Patches(rows("representative", start, stop).astype(np.int64),
                   [pieces[a:b] for a, b in zip(starts[:-1], starts[1:], strict=True)],
                   patch_points([sources[o] for o in ordered], local, source_pose, reader.attrs),
                   rows("source_volume", start, stop).astype(np.float64), [sources[o] for o in ordered], local,
                   source_pose)


def patch_points(sources: list[np.ndarray], source_object: np.ndarray, source_pose: np.ndarray,
                 attrs: dict) -> list[np.ndarray]:
    """Each patch's surface points, cut from its source at its pose (the dataset's gripper and voxel size give
    the patch box)."""
    lower, upper = patch_box(GripperSpec.model_validate(attrs["gripper"]), float(attrs["voxel"]["resolution"]))
    return [cut_points(sources[o], pose, lower, upper) for o, pose in zip(source_object, source_pose, strict=True)]


def build_patches(spec: JobSpec, reader: DatasetReader, parts: PartStore, representative: np.ndarray) -> Patches:
    """Cut the patch of every unique code from its representative's source object (read from its part)."""
    objects = reader["grasps/object"][representative].astype(np.int64)
    poses32 = reader["grasps/pose"][representative]
    poses = poses32.astype(np.float64)
    lower, upper = patch_box(spec.gripper, spec.voxel.resolution)
    pieces: list[list[np.ndarray]] = [[] for _ in representative]
    points: list[np.ndarray] = [np.zeros((0, 3))] * len(representative)
    volume = np.zeros(len(representative))
    used = np.unique(objects)
    sources = []
    for obj in used:
        source = source_geometry(reader, parts, int(obj))
        surface = as_stored(source.surface)  # 6 bytes a point
        sources.append(surface)
        for k in np.flatnonzero(objects == obj):
            rot, origin = poses[k, :3, :3], poses[k, :3, 3]
            local = [clip_to_box(rotate_points(piece - origin, rot), lower, upper) for piece in source.pieces]
            pieces[k] = [piece.astype(np.float32).astype(np.float64) for piece in local if len(piece)]  # as stored
            points[k] = cut_points(surface, poses[k], lower, upper)
            volume[k] = source.volume
    return Patches(np.asarray(representative, dtype=np.int64), pieces, points, volume, sources,
                   np.searchsorted(used, objects).astype(np.int64), poses32.astype(np.float32))


@dataclass(frozen=True)
class SourceGeometry:
    """A source object as its extraction part keeps it: surface points (S, 3), convex pieces (list of (k, 3)),
    float64, and the physics it was simulated with."""

    surface: np.ndarray
    pieces: list[np.ndarray]
    volume: float
    density: float | None  # a folder manifest's (None: the job's sim.density)
    friction: float


def source_geometry(reader: DatasetReader, parts: PartStore, obj: int) -> SourceGeometry:
    """Object ``obj``'s geometry, from its extraction part (found by its content id and the dataset's result
    key)."""
    key = part_key(bytes(reader.array("objects/id")[obj]).hex(), reader.attrs["provenance"]["result_key"])
    name = reader.object_names[obj]
    if not parts.is_committed(key):
        raise StoreError(f"{parts.path(key)}: the extraction part of {name} is missing; assembly cuts patches from "
                         "it (run the extract stage again with the same spec to recreate it)")
    arrays = {n: parts.read_array(key, n) for n in (SURFACE, PIECE_VERTICES, PIECE_SIZES)}
    sizes = arrays[PIECE_SIZES].astype(np.int64)
    meta = ObjectPartMeta.from_attrs(parts.read_meta(key))
    return SourceGeometry(surface=arrays[SURFACE].astype(np.float64),
                          pieces=np.split(arrays[PIECE_VERTICES].astype(np.float64), np.cumsum(sizes)[:-1]),
                          volume=float(meta.volume), density=meta.density, friction=float(meta.friction))
