"""Single-link URDF reading with confined mesh paths.

Only the geometry matters here: the link's visual geometry (or its collision geometry when the visual
cannot be used), with each element's origin and mesh scale applied.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.portable import sin_cos
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.paths import package_reference, relative_reference


@dataclass(frozen=True)
class GeometryElement:
    """One <geometry> child: kind 'mesh' (path, scale) or 'box'/'cylinder'/'sphere' (dims); origin (4, 4)."""

    kind: str
    origin: np.ndarray
    path: Path | None = None
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    dims: tuple[float, ...] = ()


def parse_urdf(text: str, urdf_path: Path, source: str,
               root: Path | None = None) -> tuple[list[GeometryElement], list[GeometryElement]]:
    """Visual and collision geometry of a one-link URDF. Mesh paths are confined to the URDF's folder;
    ``package://`` paths resolve through the package map of the input ``root`` (objects/paths.py)."""
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as err:
        raise MeshRejected(source, f"malformed URDF XML: {err}") from None
    if robot.tag != "robot":
        raise MeshRejected(source, f"URDF root element is <{robot.tag}>, expected <robot>")
    links = [link for link in robot.findall("link") if link.find("visual") is not None
             or link.find("collision") is not None]
    if len(links) != 1:
        raise MeshRejected(source, f"URDF has {len(links)} links with geometry; only single-link objects "
                                   "are supported")
    link = links[0]
    folder = urdf_path.parent
    visual = [_element(e, folder, source, root) for e in link.findall("visual")]
    collision = [_element(e, folder, source, root) for e in link.findall("collision")]
    return visual, collision


def mesh_reference(filename: str, folder: Path, source: str, root: Path | None) -> Path:
    """The confined file a URDF <mesh filename> names (relative to the URDF, or package:// through the map)."""
    if filename.startswith("package://") and root is not None:
        return package_reference(filename, root, source)
    return relative_reference(filename, folder, source)


def mesh_filenames(text: str) -> list[str]:
    """Every <mesh filename="..."> of a URDF, read with the XML parser (any quoting); [] if it does not parse."""
    try:
        return [mesh.get("filename", "") for mesh in ET.fromstring(text).iter("mesh") if mesh.get("filename")]
    except ET.ParseError:
        return []


def _element(node: ET.Element, folder: Path, source: str, root: Path | None = None) -> GeometryElement:
    origin = _origin(node.find("origin"), source)
    geometry = node.find("geometry")
    shape = geometry[0] if geometry is not None and len(geometry) else None
    if shape is None:
        raise MeshRejected(source, f"<{node.tag}> has no geometry")
    if shape.tag == "mesh":
        filename = shape.get("filename", "")
        if not filename:
            raise MeshRejected(source, "<mesh> has no filename")
        scale = _floats(shape.get("scale", "1 1 1"), 3, "mesh scale", source)
        return GeometryElement("mesh", origin, mesh_reference(filename, folder, source, root), tuple(scale))
    dims = {"box": ("size", 3), "cylinder": ("radius length", 2), "sphere": ("radius", 1)}.get(shape.tag)
    if dims is None:
        raise MeshRejected(source, f"unsupported URDF geometry <{shape.tag}>")
    values = [v for attr in dims[0].split() for v in _floats(shape.get(attr, ""), None, attr, source)]
    if len(values) != dims[1] or min(values) <= 0:
        raise MeshRejected(source, f"<{shape.tag}> needs {dims[1]} positive numbers, got {values}")
    return GeometryElement(shape.tag, origin, dims=tuple(values))


def _origin(node: ET.Element | None, source: str) -> np.ndarray:
    pose = np.eye(4)
    if node is None:
        return pose
    xyz = _floats(node.get("xyz", "0 0 0"), 3, "origin xyz", source)
    roll, pitch, yaw = _floats(node.get("rpy", "0 0 0"), 3, "origin rpy", source)
    (sr, sp, sy), (cr, cp, cy) = sin_cos(np.array([roll, pitch, yaw]))
    pose[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                    [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                    [-sp, cp * sr, cp * cr]]
    pose[:3, 3] = xyz
    return pose


def _floats(text: str, count: int | None, what: str, source: str) -> list[float]:
    try:
        values = [float(x) for x in text.split()]
    except ValueError:
        raise MeshRejected(source, f"URDF {what} {text!r} is not a list of numbers") from None
    if (count is not None and len(values) != count) or not np.all(np.isfinite(values)):
        raise MeshRejected(source, f"URDF {what} {text!r} must be {count or 'some'} finite numbers")
    return values
