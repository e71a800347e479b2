"""Objects from scans: a captured point cloud (or a reconstruction tool's raw mesh) becomes a clean, watertight,
metre-scaled mesh that any job can use as an object (docs/supplement.md).

Steps: read -> drop non-finite rows -> units -> statistical outlier removal -> refuse degenerate scans (too few
points, flat) -> normals (kept if given, else estimated and oriented consistently, outward) -> surface
reconstruction (open3d screened Poisson or ball pivoting) -> crop the low-density skirt -> largest component ->
hole filling -> watertight check (refusal if it fails) -> decimation -> validation -> report with the Hausdorff
distance between the mesh and the cleaned points.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from onepiece_dist.core.mesh import TriangleMesh, make_mesh, min_width, sample_surface
from onepiece_dist.core.raycast import import_open3d
from onepiece_dist.core.repair import fan_fill
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.meshio import parse_mesh_bytes, write_obj

POINT_CLOUD_SUFFIXES = (".ply", ".pcd", ".xyz", ".xyzn", ".xyzrgb", ".pts")
MESH_SCAN_SUFFIXES = (".obj", ".stl", ".ply", ".glb")
MM_PER_M = 1000.0
SKIRT_MIN_FRACTION = 0.02  # Poisson rounds sharp edges by about this share of the size: not a skirt
ORIENT_JITTER = 1e-3  # of the mean point spacing: breaks exact coplanarity for the orientation graph only


class SupplementSpec(BaseModel):
    """How a scan becomes a mesh. Lengths in metres after unit conversion."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    method: Literal["poisson", "ball_pivoting"] = Field("poisson", description="Surface reconstruction.")
    units: Literal["auto", "m", "cm", "mm"] = Field("auto", description="Units of the scan; 'auto' takes "
                                                   "millimetres when the scan is larger than auto_mm_above.")
    auto_mm_above: float = Field(3.0, gt=0, description="Bounding-box diagonal (in file units) above which "
                                 "'auto' reads millimetres.")
    min_points: int = Field(500, ge=10, description="Fewer points (after cleaning) are refused.")
    outlier_neighbours: int = Field(20, ge=2, description="Neighbours of the statistical outlier test.")
    outlier_std: float = Field(2.0, gt=0, description="Points farther than mean + std_ratio * std are outliers.")
    poisson_depth: int = Field(8, ge=4, le=12, description="Octree depth of Poisson reconstruction.")
    skirt_spacings: float = Field(4.0, gt=0, description="Poisson vertices farther than this many mean point "
                                  "spacings from every scan point (the extrapolated skirt over unscanned "
                                  "sides) are cut, then the hole is filled or the scan refused.")
    min_thickness: float = Field(0.003, gt=0, description="Scans thinner than this along their smallest "
                                 "principal axis are refused as flat (m).")
    max_diagonal: float = Field(2.0, gt=0, description="Larger objects are refused (m; catches wrong units).")
    target_triangles: int = Field(20000, ge=100, description="Decimate larger meshes to about this many.")
    max_file_bytes: int = Field(256 * 2**20, gt=0, description="Larger scan files are refused.")


class SupplementReport(BaseModel):
    """What `onepiece supplement` did, written beside the mesh as <name>.supplement.json."""

    model_config = ConfigDict(frozen=True)
    scan: str
    mesh: str
    points_in: int
    non_finite_dropped: int
    outliers_removed: int
    units: str
    scale: float
    normals: Literal["given", "estimated"]
    method: str
    triangles_out: int
    vertices_out: int
    watertight: bool
    holes_filled: bool
    volume_m3: float
    extents_m: list[float]
    min_width_m: float
    fits_gripper: bool
    hausdorff_m: float = Field(description="Symmetric Hausdorff distance between the mesh and the cleaned points.")
    mean_distance_m: float = Field(description="Mean distance of the cleaned points to the mesh.")
    warnings: list[str] = []


def supplement_scan(scan: str | os.PathLike, out_dir: str | os.PathLike, spec: SupplementSpec | None = None,
                    max_opening: float = 0.08) -> SupplementReport:
    """Turn ``scan`` into ``out_dir/<stem>.obj`` and its report; raises :class:`MeshRejected` with the reason."""
    scan, out_dir, spec = Path(scan), Path(out_dir), spec or SupplementSpec()
    points, normals, non_finite = read_scan(scan, spec.max_file_bytes)
    source = str(scan)
    units, scale = scan_units(points, spec)
    points = points * scale
    points, normals, outliers = remove_outliers(points, normals, spec)
    check_not_degenerate(points, source, spec)
    normals, normal_origin = (normals, "given") if normals is not None else (estimate_normals(points), "estimated")
    vertices, faces, filled = reconstruct(points, normals, source, spec)
    mesh = make_mesh(vertices, faces, source)
    points, stray = drop_stray_points(points, mesh, spec)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{scan.stem}.obj"
    write_obj(mesh.vertices, mesh.faces, path)
    report = _report(scan, path, mesh, points, spec, max_opening, non_finite=non_finite, outliers=outliers + stray,
                     units=units, scale=scale, normals=normal_origin, filled=filled)
    (out_dir / f"{scan.stem}.supplement.json").write_text(json.dumps(report.model_dump(), indent=2) + "\n")
    return report


def read_scan(path: Path, max_bytes: int) -> tuple[np.ndarray, np.ndarray | None, int]:
    """Points (n, 3) float64, normals (n, 3) or None, and how many non-finite rows were dropped.

    A mesh file (OBJ, STL, GLB, or a PLY with faces) is sampled on its surface.
    """
    source, suffix = str(path), path.suffix.lower()
    if not path.is_file():
        raise MeshRejected(source, "no such scan file")
    if path.stat().st_size > max_bytes:
        raise MeshRejected(source, f"file is {path.stat().st_size} bytes, over the limit of {max_bytes}")
    if suffix not in POINT_CLOUD_SUFFIXES + MESH_SCAN_SUFFIXES:
        raise MeshRejected(source, f"unsupported scan extension {suffix!r}; expected one of "
                                   f"{sorted(set(POINT_CLOUD_SUFFIXES + MESH_SCAN_SUFFIXES))}")
    points, normals = _read_mesh_scan(path) if _is_mesh(path) else _read_point_cloud(path)
    finite = np.isfinite(points).all(axis=1)
    if normals is not None:
        finite &= np.isfinite(normals).all(axis=1) & (np.linalg.norm(normals, axis=1) > 0)
        normals = normals[finite] / np.linalg.norm(normals[finite], axis=1, keepdims=True)
    return points[finite], normals, int((~finite).sum())


def _is_mesh(path: Path) -> bool:
    suffix = path.suffix.lower()
    if suffix != ".ply":
        return suffix in MESH_SCAN_SUFFIXES
    with open(path, "rb") as handle:
        header = handle.read(4096).split(b"end_header")[0]
    return b"element face" in header and b"element face 0" not in header


def _read_point_cloud(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    o3d = import_open3d()

    cloud = o3d.io.read_point_cloud(str(path), format=_o3d_format(path))
    points = np.asarray(cloud.points, dtype=np.float64)
    normals = np.asarray(cloud.normals, dtype=np.float64) if cloud.has_normals() else None
    return points, normals


def _o3d_format(path: Path) -> str:
    suffix = path.suffix.lower()[1:]
    return suffix if suffix in ("xyz", "xyzn", "xyzrgb", "pts", "pcd", "ply") else "auto"


def _read_mesh_scan(path: Path, samples: int = 50000) -> tuple[np.ndarray, np.ndarray]:
    """Points and normals sampled on a raw mesh (parsed from bytes by our own loaders)."""
    vertices, faces = parse_mesh_bytes(path.read_bytes(), path.suffix.lower(), str(path))
    mesh = make_mesh(vertices, faces, str(path))
    return sample_surface(mesh, samples, np.random.default_rng(0))


def scan_units(points: np.ndarray, spec: SupplementSpec) -> tuple[str, float]:
    """The scan's units and the factor to metres."""
    factors = {"m": 1.0, "cm": 0.01, "mm": 0.001}
    if spec.units != "auto":
        return spec.units, factors[spec.units]
    if len(points) == 0:
        return "m", 1.0
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0)))
    return ("mm", 0.001) if diagonal > spec.auto_mm_above else ("m", 1.0)


def remove_outliers(points: np.ndarray, normals: np.ndarray | None,
                    spec: SupplementSpec) -> tuple[np.ndarray, np.ndarray | None, int]:
    """Statistical outlier removal; returns the kept points, their normals and how many were removed."""
    o3d = import_open3d()

    if len(points) <= spec.outlier_neighbours:
        return points, normals, 0
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    _, kept = cloud.remove_statistical_outlier(spec.outlier_neighbours, spec.outlier_std)
    kept = np.asarray(kept, dtype=np.int64)
    return points[kept], None if normals is None else normals[kept], len(points) - len(kept)


def check_not_degenerate(points: np.ndarray, source: str, spec: SupplementSpec) -> None:
    """Refuse scans that cannot bound a solid: too few points, flat, or of an implausible size."""
    if len(points) < spec.min_points:
        raise MeshRejected(source, f"too few points: {len(points)} after cleaning, at least {spec.min_points} "
                                   "are needed to reconstruct a surface")
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0)))
    if diagonal > spec.max_diagonal:
        raise MeshRejected(source, f"scan is {diagonal:.3f} m across, over max_diagonal={spec.max_diagonal} m "
                                   "(wrong units? pass --units)")
    thickness = min_width(points)
    if thickness < spec.min_thickness:
        raise MeshRejected(source, f"scan is flat: its points lie within {thickness * MM_PER_M:.2f} mm of a plane "
                                   f"(min_thickness={spec.min_thickness * MM_PER_M:.1f} mm); a closed surface "
                                   "cannot be reconstructed from one side")


def estimate_normals(points: np.ndarray) -> np.ndarray:
    """(n, 3) unit normals, oriented consistently over the surface and outward (away from the interior)."""
    o3d = import_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    spacing = mean_spacing(points)
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=4 * spacing, max_nn=30))
    normals = np.asarray(cloud.normals) * consistent_signs(points, np.asarray(cloud.normals), spacing)[:, None]
    outward = np.einsum("ij,ij->i", points - points.mean(axis=0), normals)
    return -normals if np.sum(outward) < 0 else normals


def consistent_signs(points: np.ndarray, normals: np.ndarray, spacing: float) -> np.ndarray:
    """(n,) float +1 or -1 per normal (n, 3) that orient the normals consistently over the surface: open3d's
    tangent-plane propagation (k = 15), on a copy of the points (n, 3) moved by a seeded ORIENT_JITTER x
    ``spacing``. On exactly coplanar points (a CAD model's samples, a synthetic scan) open3d builds its graph
    about 30 times slower (isl-org/Open3D#6482; 28 s against 0.9 s for 20,000 points of a box)."""
    o3d = import_open3d()

    moved = points + np.random.default_rng(0).normal(0.0, ORIENT_JITTER * spacing, points.shape)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(moved))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    cloud.orient_normals_consistent_tangent_plane(15)
    return np.sign(np.einsum("ij,ij->i", np.asarray(cloud.normals), normals))


def reconstruct(points: np.ndarray, normals: np.ndarray, source: str,
                spec: SupplementSpec) -> tuple[np.ndarray, np.ndarray, bool]:
    """Watertight triangle mesh of an oriented point cloud: vertices (V, 3), faces (F, 3), holes filled?"""
    o3d = import_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    mesh = _poisson(cloud, spec) if spec.method == "poisson" else _ball_pivoting(cloud)
    mesh = _largest_component(mesh)
    filled = False
    if not _watertight(mesh):
        mesh, filled = _fill_holes(mesh), True
    if not _watertight(mesh):
        raise MeshRejected(source, f"{spec.method} reconstruction is not watertight even after hole filling "
                                   f"({_boundary_edges(mesh)} open edges): the scan has gaps too large to close; "
                                   + ("capture the missing side" if spec.method == "poisson" else
                                      "try method=poisson, which tolerates noise and sparse regions"))
    vertices, faces = _decimate(mesh, spec.target_triangles)
    return vertices, faces, filled


def _poisson(cloud, spec: SupplementSpec):
    o3d = import_open3d()

    # one thread: its threads add in an order that changes from run to run, and so did the mesh (issue 50)
    mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=spec.poisson_depth, n_threads=1)
    spacing = mean_spacing(np.asarray(cloud.points))
    vertices = o3d.geometry.PointCloud(mesh.vertices)
    distance = np.asarray(vertices.compute_point_cloud_distance(cloud))
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(cloud.points), axis=0)))
    mesh.remove_vertices_by_mask(distance > max(spec.skirt_spacings * spacing, SKIRT_MIN_FRACTION * diagonal))
    return mesh


def _ball_pivoting(cloud):
    o3d = import_open3d()

    spacing = mean_spacing(np.asarray(cloud.points))
    radii = o3d.utility.DoubleVector([3 * spacing, 6 * spacing, 12 * spacing])
    return o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(cloud, radii)


def _largest_component(mesh):
    mesh.remove_duplicated_vertices()
    mesh.remove_degenerate_triangles()
    mesh.remove_duplicated_triangles()
    mesh.remove_non_manifold_edges()
    clusters, sizes, _ = mesh.cluster_connected_triangles()
    clusters, sizes = np.asarray(clusters), np.asarray(sizes)
    if len(sizes) > 1:
        mesh.remove_triangles_by_mask(clusters != int(np.argmax(sizes)))
        mesh.remove_unreferenced_vertices()
    return mesh


def _fill_holes(mesh):
    """Close each boundary loop with a fan of triangles around the loop's centroid (open3d's own
    ``fill_holes`` in 0.18-0.20 now and then writes garbage vertex positions). Non-manifold boundaries stay
    open and the watertight check refuses them."""
    o3d = import_open3d()

    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    new_vertices, new_faces = fan_fill(vertices, faces)
    filled = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(new_vertices),
                                       o3d.utility.Vector3iVector(new_faces))
    return filled


def _boundary_edges(mesh) -> int:
    """Edges not shared by exactly two triangles (open or non-manifold)."""
    faces = np.asarray(mesh.triangles)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int(np.sum(counts != 2))


def _watertight(mesh) -> bool:
    """Every edge shared by exactly two triangles (a closed 2-manifold surface)."""
    return len(mesh.triangles) > 0 and _boundary_edges(mesh) == 0


def _decimate(mesh, target: int) -> tuple[np.ndarray, np.ndarray]:
    if len(mesh.triangles) > target:
        smaller = mesh.simplify_quadric_decimation(target)
        if _watertight(smaller) and _inside_bounds(smaller, mesh):
            mesh = smaller
    mesh.orient_triangles()
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.triangles, dtype=np.int64)


def _inside_bounds(smaller, mesh, slack: float = 0.01) -> bool:
    """Quadric decimation in open3d 0.18-0.20 now and then places a vertex at a huge or NaN position (a
    singular quadric on flat regions); such a result is discarded."""
    vertices = np.asarray(smaller.vertices)
    lower, upper = mesh.get_min_bound(), mesh.get_max_bound()
    margin = slack * float(np.linalg.norm(upper - lower))
    return bool(np.isfinite(vertices).all() and np.all(vertices >= lower - margin)
                and np.all(vertices <= upper + margin))


def mean_spacing(points: np.ndarray) -> float:
    """Mean distance from each point (n, 3) to its nearest neighbour."""
    o3d = import_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return float(np.mean(cloud.compute_nearest_neighbor_distance()))


def drop_stray_points(points: np.ndarray, mesh: TriangleMesh, spec: SupplementSpec) -> tuple[np.ndarray, int]:
    """Outliers the statistical test kept: points farther from the reconstructed surface than the skirt
    distance. Returns the rest and how many were dropped."""
    near = point_mesh_distances(points, mesh) <= spec.skirt_spacings * mean_spacing(points)
    return points[near], int((~near).sum())


def point_mesh_distances(points: np.ndarray, mesh: TriangleMesh) -> np.ndarray:
    """(n,) unsigned distance from each point to the mesh surface (open3d raycasting scene)."""
    o3d = import_open3d()

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32))
    return scene.compute_distance(points.astype(np.float32)).numpy().astype(np.float64)


def hausdorff(points: np.ndarray, mesh: TriangleMesh, samples: int = 20000) -> tuple[float, float]:
    """Symmetric Hausdorff distance between points (n, 3) and a mesh, and the mean point-to-mesh distance."""
    o3d = import_open3d()

    to_mesh = point_mesh_distances(points, mesh)
    surface, _ = sample_surface(mesh, samples, np.random.default_rng(0))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    samples_cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(surface))
    to_points = np.asarray(samples_cloud.compute_point_cloud_distance(cloud))
    return float(max(to_mesh.max(), to_points.max())), float(to_mesh.mean())


def _report(scan: Path, path: Path, mesh: TriangleMesh, points: np.ndarray, spec: SupplementSpec,
            max_opening: float, **facts) -> SupplementReport:
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    distance, mean = hausdorff(points, mesh)
    width = min_width(mesh.vertices)
    warnings = [] if width <= max_opening else [
        f"narrowest extent {width * MM_PER_M:.1f} mm exceeds the gripper opening {max_opening * MM_PER_M:.0f} mm: "
        "only protruding parts can be grasped"]
    if facts["filled"]:
        warnings.append(f"holes were closed with flat fans; the mesh lies up to {distance * MM_PER_M:.1f} mm from "
                        "the scan there (capture those sides for a faithful model)")
    return SupplementReport(
        scan=str(scan), mesh=str(path), points_in=len(points) + facts["outliers"] + facts["non_finite"],
        non_finite_dropped=facts["non_finite"], outliers_removed=facts["outliers"], units=facts["units"],
        scale=facts["scale"], normals=facts["normals"], method=spec.method, triangles_out=len(mesh.faces),
        vertices_out=len(mesh.vertices), watertight=bool(tm.is_watertight), holes_filled=facts["filled"],
        volume_m3=float(abs(tm.volume)), extents_m=[float(x) for x in mesh.extents], min_width_m=width,
        fits_gripper=width <= max_opening, hausdorff_m=distance, mean_distance_m=mean, warnings=warnings)
