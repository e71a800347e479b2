"""The assemble stage (run by the central actor after the dataset is committed): classify every unique code, lay
its patch (real geometry, job/patches.py) out on the one object, prove the round trip (codes and Chamfer
distance to the representatives' points), and store it under ``assembled/``; export as OBJ, PLY or URDF."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from onepiece_dist.core.assembly_layout import (
    assembly_geometry,
    corridor_intrusions,
    cube_points,
    layout_patches,
    placed_points,
    placement_point_grid,
    region_codes,
)
from onepiece_dist.core.classifier import PLANES, classify_codes
from onepiece_dist.core.clip import hull_mesh
from onepiece_dist.core.frames import transform_points
from onepiece_dist.core.mesh import solid_properties
from onepiece_dist.core.voxel import crop_points
from onepiece_dist.errors import MissingAssembly
from onepiece_dist.job.patches import Patches, read_patches
from onepiece_dist.job.status import AssemblyReport
from onepiece_dist.objects.meshio import write_obj, write_ply
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store.dataset import DatasetReader, write_group

URDF_TEMPLATE = """<?xml version="1.0"?>
<robot name="{name}">
  <link name="{link}">
    <inertial><origin xyz="{com}"/><mass value="{mass:.9g}"/>
      <inertia ixx="{ixx:.6g}" ixy="{ixy:.6g}" ixz="{ixz:.6g}" iyy="{iyy:.6g}" iyz="{iyz:.6g}"
               izz="{izz:.6g}"/></inertial>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
    <collision><geometry><mesh filename="{pieces}"/></geometry></collision>
  </link>
</robot>
"""
CHAMFER_PATCHES = 200  # patches whose crop is compared with the representative's stored points (a fixed sample)


def assemble_dataset(spec: JobSpec, path: str | os.PathLike, codes: np.ndarray, patches: Patches,
                     grasps: int) -> AssemblyReport:
    """Lay out the ``patches`` of the unique ``codes`` (U, B) uint8 of the dataset at ``path`` (which holds
    ``grasps`` grasps) as one object, check it, and store it under ``assembled/``; returns the report."""
    grid, res, gripper = spec.grid_shape(), spec.voxel.resolution, spec.gripper
    classes = classify_codes(codes, grid)
    layout = layout_patches(classes.plane, gripper, res)
    geometry = assembly_geometry(layout, patches.pieces, patches.points, res)
    index = placement_point_grid(geometry["points"], gripper, grid, res)
    seen = region_codes(geometry["points"], layout.placements, grid, res, index=index)
    matches = np.all(seen == codes, axis=1)
    intrusions = corridor_intrusions(geometry["points"], geometry["point_patch"], layout.placements, gripper,
                                     reach=float(np.ptp(layout.bounding_box, axis=0).max()) + 1.0, index=index)
    del index
    chamfer = _chamfer_to_representatives(spec, path, patches)
    report = _report(spec, grasps, codes, classes, layout, matches, intrusions, chamfer, patches)
    del geometry["points"], geometry["point_patch"]  # derived again on demand (one_object_points): not stored
    arrays = {"placement": layout.placements.astype(np.float32), "plane": classes.plane,
              "areas": classes.areas, "features": classes.features, "scores": classes.scores.astype(np.float32),
              "vertices": geometry["vertices"].astype(np.float32), "faces": geometry["faces"].astype(np.int32),
              "face_group": geometry["face_group"], "core_half": layout.core_half.astype(np.float64),
              "code_count": _code_counts(path), **patches.arrays()}
    write_group(path, "assembled", arrays, {"assembly": report.model_dump(mode="json")})
    return report


def _chamfer_to_representatives(spec: JobSpec, path, patches: Patches) -> np.ndarray:
    """(n,) symmetric mean Chamfer distance (m) between each sampled patch's crop (its closing region) and its
    representative's stored points (unique/points), for up to CHAMFER_PATCHES patches; empty without points."""
    reader = DatasetReader(path)
    if not reader.has("unique/points") or not len(patches):
        return np.zeros(0)
    picked = np.unique(np.linspace(0, len(patches) - 1, min(CHAMFER_PATCHES, len(patches))).astype(np.int64))
    stored = reader.array("unique/points").oindex[picked].astype(np.float64)
    grid, res = spec.grid_shape(), spec.voxel.resolution
    out = []
    for k, theirs in zip(picked, stored, strict=True):
        ours = crop_points(patches.points[k], np.eye(4), grid, res)
        out.append(chamfer_distance(ours, theirs) if len(ours) else np.nan)
    return np.array(out)


def chamfer_distance(a: np.ndarray, b: np.ndarray, rows: int = 256) -> float:
    """Symmetric mean nearest-neighbour distance between point sets (n, 3) and (m, 3) (brute force, ``rows``
    points of ``a`` at a time: (rows, m) squared distances summed per coordinate, no (n, m, 3) temporary, and one
    square root per nearest neighbour: the same distances as the root of every pair's, since the root is
    monotonic)."""
    to_b, to_a = np.empty(len(a)), np.full(len(b), np.inf)
    for start in range(0, len(a), rows):
        block = a[start:start + rows]
        squared = (block[:, 0, None] - b[:, 0]) ** 2
        squared += (block[:, 1, None] - b[:, 1]) ** 2
        squared += (block[:, 2, None] - b[:, 2]) ** 2
        to_b[start:start + rows] = squared.min(axis=1)
        np.minimum(to_a, squared.min(axis=0), out=to_a)
    return float((np.sqrt(to_b).mean() + np.sqrt(to_a).mean()) / 2)


def _report(spec: JobSpec, grasps: int, codes, classes, layout, matches, intrusions, chamfer,
            patches: Patches) -> AssemblyReport:
    size = np.ptp(layout.bounding_box, axis=0)
    face_area = sum(float(np.prod(size[[i for i in range(3) if i != f]])) for f in range(3))
    trials_per_patch = spec.sim.label_trials_per_patch()
    finite = chamfer[np.isfinite(chamfer)]
    return AssemblyReport(
        unique_codes=int(len(codes)),
        grasps_represented=grasps,
        plane_counts={p: int(np.sum(classes.plane == k)) for k, p in enumerate(PLANES)},
        bounding_box_m=[round(float(x), 4) for x in size],
        patch_density_per_m2=round(len(codes) / face_area, 1) if face_area else 0.0,
        grid_pitch_m=[round(x, 4) for x in layout.pitch],
        patch_pieces=int(sum(len(p) for p in patches.pieces)),
        fidelity=float(np.mean(matches)) if len(matches) else 1.0,
        fidelity_failures=[int(i) for i in np.flatnonzero(~matches)[:100]],
        chamfer_mm=round(float(finite.mean()) * 1000, 4) if len(finite) else None,
        chamfer_max_mm=round(float(finite.max()) * 1000, 4) if len(finite) else None,
        chamfer_patches=int(len(finite)),
        corridor_intrusions=int(intrusions.sum()),
        label_trials_one_object=int(len(codes) * trials_per_patch),
        label_trials_all_grasps=int(grasps * spec.sim.label_trials),
    )


def export_assembly(path: str | os.PathLike, fmt: str, out: str | os.PathLike) -> list[Path]:
    """Write the assembled object as OBJ, PLY or URDF (with two OBJs beside it: the union mesh for drawing and
    the placed convex pieces, one ``o`` group each, for collision). Returns the files written."""
    reader = DatasetReader(path)
    if not reader.has("assembled/vertices"):
        raise MissingAssembly(f"{path}: no assembled object (run the assemble stage)")
    vertices, faces = reader["assembled/vertices"].astype(np.float64), reader["assembled/faces"]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "obj":
        write_obj(vertices, faces, out)
        return [out]
    if fmt == "ply":
        write_ply(vertices, faces, out)
        return [out]
    pieces = placed_pieces(reader)
    mesh, collision = out.with_suffix(".obj"), out.with_name(f"{out.stem}.pieces.obj")
    write_obj(vertices, faces, mesh)
    write_pieces_obj(pieces, collision)
    density = JobSpec.model_validate(reader.attrs["job_spec"]).sim.density  # the density its labels used
    mass, com, inertia = solid_of_pieces(pieces, density)
    out.write_text(URDF_TEMPLATE.format(
        name="onepiece_assembly", link="assembly", com=" ".join(f"{x:.6g}" for x in com), mass=mass, mesh=mesh.name,
        pieces=collision.name,
        ixx=inertia[0, 0], ixy=inertia[0, 1], ixz=inertia[0, 2], iyy=inertia[1, 1], iyz=inertia[1, 2],
        izz=inertia[2, 2]))
    return [out, mesh, collision]


def _code_counts(path) -> np.ndarray:
    """(U,) int64 extracted grasps each patch stands for (unique/count), kept with the one object so that it needs
    none of the extraction records."""
    return DatasetReader(path)["unique/count"].astype(np.int64)


def one_object_points(reader: DatasetReader) -> tuple[np.ndarray, np.ndarray]:
    """The one object's dense point cloud, derived from what the store keeps: every patch's points (cut from its
    source at its pose) placed by its stored placement (as the label stage places them), then the core box's.
    -> (P, 3) float32, (P,) int32 patch of each point (-1 = core)."""
    patches = read_patches(reader)
    core_half = reader["assembled/core_half"].astype(np.float64)
    res = float(reader.attrs["voxel"]["resolution"])
    per_side = max(2, int(np.ceil(2 * core_half.max() / res)))
    core = cube_points(np.zeros((1, 3)), 2 * core_half, per_side)
    points, owner = placed_points(patches.points, reader["assembled/placement"].astype(np.float64), core)
    return points.astype(np.float32), owner


def placed_pieces(reader: DatasetReader) -> list[np.ndarray]:
    """Every patch's convex pieces placed on the one object, then the core box: (k, 3) point arrays."""
    patches = read_patches(reader)
    placements = reader["assembled/placement"].astype(np.float64)
    pieces = [transform_points(piece, placements[k]) for k, patch in enumerate(patches.pieces) for piece in patch]
    core = reader["assembled/vertices"][-8:].astype(np.float64)  # the core box is the last mesh of the union
    return [*pieces, core]


def solid_of_pieces(pieces: list[np.ndarray], density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), centre of mass (3,) and inertia (3, 3) about it of the union of convex pieces, each counted
    whole (pieces of one patch may overlap slightly, as the decomposition's hulls do)."""
    parts = [solid_properties(*hull_mesh(piece)) for piece in pieces]
    volume = sum(v for v, _, _ in parts)
    com = sum(v * c for v, c, _ in parts) / volume
    inertia = sum(i + v * (np.dot(c - com, c - com) * np.eye(3) - np.outer(c - com, c - com)) for v, c, i in parts)
    return density * volume, com, density * inertia


def write_pieces_obj(pieces: list[np.ndarray], path: Path) -> None:
    """An OBJ with one ``o`` group (the hull's triangles) per convex piece: pybullet reads it as a compound."""
    lines, first = [], 1
    for k, piece in enumerate(pieces):
        vertices, faces = hull_mesh(piece)
        lines.append(f"o piece{k}")
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
        lines += [f"f {a + first} {b + first} {c + first}" for a, b, c in faces]
        first += len(vertices)
    path.write_text("\n".join(lines) + "\n")
