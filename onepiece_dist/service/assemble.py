"""The assemble stage (run by the central actor after the dataset is committed): classify every unique code,
lay the patches out as one object, prove the round trip, and store it under ``assembled/``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from onepiece_dist.core.classifier import PLANES, classify_codes
from onepiece_dist.core.layout import assembly_geometry, corridor_intrusions, layout_patches, region_codes
from onepiece_dist.errors import MissingAssembly
from onepiece_dist.objects.meshio import write_obj, write_ply
from onepiece_dist.service.status import AssemblyReport
from onepiece_dist.spec import JobSpec
from onepiece_dist.store.dataset import DatasetReader, write_group

URDF_TEMPLATE = """<?xml version="1.0"?>
<robot name="onepiece_assembly">
  <link name="assembly">
    <inertial><origin xyz="0 0 0"/><mass value="{mass:.6g}"/>
      <inertia ixx="{inertia:.6g}" ixy="0" ixz="0" iyy="{inertia:.6g}" iyz="0" izz="{inertia:.6g}"/></inertial>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
    <collision><geometry><mesh filename="{mesh}"/></geometry></collision>
  </link>
</robot>
"""


def assemble_dataset(spec: JobSpec, path: str | os.PathLike, codes: np.ndarray, grasps: int) -> AssemblyReport:
    """Assemble the unique ``codes`` (U, B) uint8 of the dataset at ``path``, which holds ``grasps`` grasps, into
    one object; returns (and stores under ``assembled/``) the report."""
    grid, res, gripper = spec.grid_shape(), spec.voxel.resolution, spec.gripper
    classes = classify_codes(codes, grid)
    layout = layout_patches(codes, classes.plane, grid, res, gripper)
    geometry = assembly_geometry(layout, res)
    seen = region_codes(geometry["points"], layout.placements, grid, res)
    matches = np.all(seen == codes, axis=1)
    intrusions = corridor_intrusions(geometry["points"], geometry["point_patch"], layout.placements, gripper,
                                     reach=float(np.ptp(layout.bounding_box, axis=0).max()) + 1.0)
    report = _report(grasps, codes, classes, layout, matches, intrusions)
    arrays = {"placement": layout.placements.astype(np.float32), "plane": classes.plane,
              "areas": classes.areas, "features": classes.features, "scores": classes.scores.astype(np.float32),
              "vertices": geometry["vertices"].astype(np.float32), "faces": geometry["faces"].astype(np.int32),
              "face_group": geometry["face_group"], "points": geometry["points"].astype(np.float32),
              "point_patch": geometry["point_patch"].astype(np.int32),
              "cube_centre": layout.cube_centres.astype(np.float32), "cube_patch": layout.cube_patch.astype(np.int32)}
    write_group(path, "assembled", arrays, {"assembly": report.model_dump(mode="json")})
    return report


def _report(grasps: int, codes, classes, layout, matches, intrusions) -> AssemblyReport:
    size = np.ptp(layout.bounding_box, axis=0)
    face_area = sum(float(np.prod(size[[i for i in range(3) if i != f]])) for f in range(3))
    return AssemblyReport(
        unique_codes=int(len(codes)),
        grasps_represented=grasps,
        plane_counts={p: int(np.sum(classes.plane == k)) for k, p in enumerate(PLANES)},
        bounding_box_m=[round(float(x), 4) for x in size],
        patch_density_per_m2=round(len(codes) / face_area, 1) if face_area else 0.0,
        grid_pitch_m=[round(x, 4) for x in layout.pitch],
        fidelity=float(np.mean(matches)) if len(matches) else 1.0,
        fidelity_failures=[int(i) for i in np.flatnonzero(~matches)[:100]],
        corridor_intrusions=int(intrusions.sum()),
        label_trials_one_object=int(len(codes)),
        label_trials_all_grasps=grasps,
    )


def export_assembly(path: str | os.PathLike, fmt: str, out: str | os.PathLike) -> list[Path]:
    """Write the assembled object as OBJ, PLY or URDF (+ its OBJ beside it). Returns the files written."""
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
    mesh = out.with_suffix(".obj")
    write_obj(vertices, faces, mesh)
    extent = float(np.ptp(vertices, axis=0).max())
    mass = 1.0
    out.write_text(URDF_TEMPLATE.format(mass=mass, inertia=mass * extent**2 / 6, mesh=mesh.name))
    return [out, mesh]
