"""The one object for other simulators: one URDF per patch, placed as on the one object, each with the mass rule
our label stage uses (docs/assembly.md), and a scene file listing them.

The single compound URDF (``onepiece export --format urdf``) is one rigid body of all patches, its mass the whole
assembly's: a simulator that lifts it lifts every patch at once. Our label stage simulates each patch as a body of
its own, of mass ``sim.density`` x its source object's volume (clipped to the simulator's mass bounds), its centre
of mass at the centroid of its convex pieces. Here each patch is such a body, in its own (gripper) frame, so a
grasp at the patch's placement in another simulator closes on what our label trials closed on.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from onepiece_dist.core.frames import quat_from_matrix
from onepiece_dist.errors import MissingAssembly
from onepiece_dist.job.exports.grasp_files import ExportFolder
from onepiece_dist.job.patches import read_patches
from onepiece_dist.job.stages.assemble import URDF_TEMPLATE, solid_of_pieces, write_pieces_obj
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import DatasetReader


def patch_mass(source_volume: float, density: float) -> float:
    """The label stage's mass rule for one patch (kg): density x source volume within the simulator's bounds."""
    from onepiece_dist.sim.world import MAX_MASS, MIN_MASS

    return float(np.clip(density * source_volume, MIN_MASS, MAX_MASS))


def export_patches(path: str | os.PathLike, out: str | os.PathLike) -> list[Path]:
    """``out/patches/patch_K.urdf`` (+ its OBJ of convex pieces, one ``o`` group each) per patch with pieces, and
    ``out/scene.json``: for each, the URDF, its pose on the one object (4x4 and position + xyzw quaternion), mass,
    centre of mass and source object. Returns the files written."""
    reader = DatasetReader(path)
    if not reader.has("assembled/placement"):
        raise MissingAssembly(f"{path}: no assembled object (run the assemble stage)")
    spec = JobSpec.model_validate(reader.attrs["job_spec"])
    patches = read_patches(reader)
    placements = reader["assembled/placement"].astype(np.float64)
    sources = reader["grasps/object"][patches.representative].astype(np.int64)
    names = reader.object_names
    folder, bodies = ExportFolder(out), []
    for k, pieces in enumerate(patches.pieces):
        if not pieces:
            continue  # nothing of the source object in the patch box: the label stage skips it too
        mass = patch_mass(float(patches.source_volume[k]), spec.sim.density)
        com = np.vstack(pieces).mean(axis=0)  # as SimWorld.load_object places it
        volume, _, unit_inertia = solid_of_pieces(pieces, 1.0)
        inertia = unit_inertia * (mass / max(volume, 1e-12))  # the hulls' inertia, scaled to the rule's mass
        write_pieces_obj(pieces, folder.path(f"patches/patch_{k}.obj"))
        folder.path(f"patches/patch_{k}.urdf").write_text(URDF_TEMPLATE.format(
            name=f"patch_{k}", link="patch", com=" ".join(f"{x:.9g}" for x in com), mass=mass, mesh=f"patch_{k}.obj",
            pieces=f"patch_{k}.obj",
            ixx=inertia[0, 0], ixy=inertia[0, 1], ixz=inertia[0, 2], iyy=inertia[1, 1], iyz=inertia[1, 2],
            izz=inertia[2, 2]))
        pose = placements[k]
        bodies.append({"patch": k, "urdf": f"patches/patch_{k}.urdf", "pose": pose.tolist(),
                       "position": pose[:3, 3].tolist(), "orientation_xyzw": list(quat_from_matrix(pose[:3, :3])),
                       "mass": mass, "com": com.tolist(), "source_object": names[int(sources[k])],
                       "source_volume": float(patches.source_volume[k])})
    scene = folder.path("scene.json")
    scene.write_text(json.dumps({
        "frame": "each patch in its own frame, the gripper frame of its representative grasp (columns u, v, t); "
                 "pose: patch frame to the one object's frame, as assembled/placement",
        "mass_rule": f"sim.density ({spec.sim.density} kg/m^3) x the source object's volume, clipped to the "
                     "label stage's bounds; centre of mass at the pieces' centroid",
        "label_load": spec.sim.load, "payload_kg": spec.sim.load_mass if spec.sim.load == "grasp" else None,
        "patches": bodies}, indent=1) + "\n")
    return folder.written

