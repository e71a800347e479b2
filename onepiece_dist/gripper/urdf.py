"""A parallel gripper read from a URDF's finger links: ``gripper: {urdf: path/to/hand.urdf}`` in a job spec.

The two prismatic joints whose child links are fingers (their names say "finger") give the closing axis (the
joint axis), the stroke (both joints' upper limits: the Panda's 0-4 cm each give 8 cm), the closing force (the
joints' effort limit: what the URDF allows, which may be below the vendor's datasheet) and the approach direction
(from the hand to the fingers' joint origin, whose distance is the palm depth). The finger link's collision
geometry (a mesh or a box, in the finger's frame) gives the finger's length (along the approach), its thickness
(along the closing axis) and its height; the hand link's collision geometry its height. The closing region is the
largest box of whole voxels between the fingers. Read where the spec is made (CLI, API): a worker gets the fields.
pybullet_data ships the Franka Panda's (``franka_panda/panda.urdf``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.errors import SpecError

VOXEL = 0.01  # m: the default voxel resolution; the closing region is whole voxels of it


@dataclass(frozen=True)
class FingerJoint:
    parent: str
    child: str
    origin: np.ndarray  # (3,) in the parent (hand) frame
    axis: np.ndarray  # (3,) unit, in the parent frame
    upper: float
    effort: float


def gripper_from_urdf(path: str | Path, voxel: float = VOXEL) -> dict[str, float | str]:
    """GripperSpec fields of the parallel gripper the URDF at ``path`` describes. Raises SpecError naming the
    file and what is missing."""
    path = Path(path)
    try:
        robot = ET.fromstring(path.read_text())
    except (OSError, ET.ParseError) as err:
        raise SpecError(f"gripper.urdf: cannot read {path}: {err}") from None
    joints = _finger_joints(robot, path)
    first = joints[0]
    approach = first.origin / max(np.linalg.norm(first.origin), 1e-12)
    if np.linalg.norm(first.origin) < 1e-6 or abs(approach @ first.axis) > 1e-6:
        raise SpecError(f"gripper.urdf: {path}: the finger joint's origin must lie along the approach, away from "
                        "the hand and across the closing axis")
    height_axis = np.cross(approach, first.axis)
    finger = _collision_points(robot, first.child, path)
    hand = _collision_points(robot, first.parent, path)
    extent = lambda points, axis: float(np.ptp(points @ axis)) if len(points) else 0.0  # noqa: E731
    length, thickness, height = (extent(finger, a) for a in (approach, first.axis, height_axis))
    opening = float(sum(j.upper for j in joints))
    whole = lambda size: float(max(voxel, np.floor(size / voxel + 1e-9) * voxel))  # noqa: E731
    return {"name": robot.get("name", path.stem), "max_opening": opening, "finger_length": length,
            "finger_thickness": thickness, "finger_height": height, "palm_depth": float(np.linalg.norm(first.origin)),
            "palm_height": max(extent(hand, height_axis), height), "closing_depth": min(whole(length), length),
            "closing_width": min(whole(opening), opening), "closing_height": min(whole(height), height),
            "closing_force": float(min(j.effort for j in joints)),
            "finger_mass": _mass(robot, first.child)}


def _finger_joints(robot: ET.Element, path: Path) -> list[FingerJoint]:
    found = []
    for joint in robot.iter("joint"):
        child = joint.find("child").get("link") if joint.find("child") is not None else ""
        if joint.get("type") != "prismatic" or "finger" not in child.lower():
            continue
        limit = joint.find("limit")
        origin = joint.find("origin")
        axis = np.array(_floats(joint.find("axis").get("xyz", "1 0 0") if joint.find("axis") is not None else "1 0 0"))
        found.append(FingerJoint(joint.find("parent").get("link"), child,
                                 np.array(_floats(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0")),
                                 axis / np.linalg.norm(axis), float(limit.get("upper", 0)) if limit is not None else 0,
                                 float(limit.get("effort", 0)) if limit is not None else 0))
    if len(found) != 2 or found[0].parent != found[1].parent:
        raise SpecError(f"gripper.urdf: {path} has {len(found)} prismatic joints to links named '*finger*' "
                        "under one hand link; a parallel gripper needs two (rename its finger links, or give "
                        "the gripper's fields instead)")
    if min(j.upper for j in found) <= 0 or min(j.effort for j in found) <= 0:
        raise SpecError(f"gripper.urdf: {path}: the finger joints need <limit upper> and <limit effort> above 0")
    return found


def _link(robot: ET.Element, name: str) -> ET.Element:
    return next(link for link in robot.iter("link") if link.get("name") == name)


def _mass(robot: ET.Element, name: str) -> float:
    mass = _link(robot, name).find("inertial/mass")
    return float(mass.get("value")) if mass is not None else 0.02


def _collision_points(robot: ET.Element, name: str, path: Path) -> np.ndarray:
    """(k, 3) vertices of the link's collision geometry in the link's frame (meshes and boxes)."""
    points = []
    for collision in _link(robot, name).iter("collision"):
        origin = collision.find("origin")
        xyz = np.array(_floats(origin.get("xyz", "0 0 0"))) if origin is not None else np.zeros(3)
        rpy = _floats(origin.get("rpy", "0 0 0")) if origin is not None else [0.0, 0.0, 0.0]
        local = _geometry_points(collision.find("geometry"), path)
        points.append(local @ _rotation(*rpy).T + xyz)
    return np.vstack(points) if points else np.zeros((0, 3))


def _geometry_points(geometry: ET.Element, path: Path) -> np.ndarray:
    box, mesh = geometry.find("box"), geometry.find("mesh")
    if box is not None:
        size = np.array(_floats(box.get("size")))
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * size / 2
    if mesh is None:
        return np.zeros((0, 3))
    import trimesh

    filename = mesh.get("filename", "").split("://", 1)[-1]
    root = path.parent.resolve()
    file = (root / filename).resolve()
    if not file.is_relative_to(root) or not file.is_file():
        raise SpecError(f"gripper.urdf: {path}: mesh {mesh.get('filename')!r} is not a file under {root}")
    scale = np.array(_floats(mesh.get("scale", "1 1 1")))
    return np.asarray(trimesh.load(file, force="mesh", process=False).vertices, dtype=np.float64) * scale


def _floats(text: str) -> list[float]:
    return [float(x) for x in text.split()]


def _rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, sr), (cp, sp), (cy, sy) = ((np.cos(a), np.sin(a)) for a in (roll, pitch, yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])
