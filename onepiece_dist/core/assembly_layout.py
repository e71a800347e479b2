"""Assembling the patches of the unique codes into ONE object (docs/assembly.md).

Each unique code has a patch: real geometry in its own gripper frame (convex pieces and surface points inside the
patch box, :func:`patch_box`). Patches are grouped by their projection-plane class onto the +X (uv), +Y (ut) and
+Z (vt) faces of a core box; on a face they sit in a grid, floating a gap above the face, and the gripper for a
patch approaches along the face's inward normal (u = -n), as it did on the source object. The grid pitch is the
smallest that keeps every neighbour out of the gripper's corridor (closing region, open fingers and the path of
the palm), so no patch masks or stacks on another and a gripper at a patch's placement sees exactly that patch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.clip import hull_mesh
from onepiece_dist.core.frames import pose_from_axes, to_gripper_frame, transform_points
from onepiece_dist.core.mesh import merge_meshes
from onepiece_dist.core.spatial import PointGrid, posed_box_bounds
from onepiece_dist.core.voxel import crop_codes
from onepiece_dist.specs.job import GripperSpec

PATCH_MARGIN = 0.005  # m: the patch box's reach beyond the closing region across the fingers' width and height
PATCH_SUPPORT = 0.01  # m: material kept beyond the fingertips (what supports the surface the pads hold)
# face k: outward normal, v axis, t axis (all world axes)
FACES = (
    (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])),
    (np.array([0, 1.0, 0]), np.array([0, 0, 1.0]), np.array([1.0, 0, 0])),
    (np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])),
)


@dataclass(frozen=True)
class Layout:
    """placements (U, 4, 4) gripper poses in the object frame; face (U,) int8; core_half (3,) half extents of the
    core box (m); pitch (v, t) (m); extent (2, 3) the patch box (gripper frame) every patch fits in."""

    placements: np.ndarray
    face: np.ndarray
    core_half: np.ndarray
    pitch: tuple[float, float]
    extent: np.ndarray

    @property
    def bounding_box(self) -> np.ndarray:
        """(2, 3) lower and upper corners of the whole object (patch boxes and core)."""
        corners = np.array([[x, y, z] for x in self.extent[:, 0] for y in self.extent[:, 1]
                            for z in self.extent[:, 2]])
        placed = np.einsum("pij,cj->pci", self.placements[:, :3, :3], corners) + self.placements[:, None, :3, 3]
        placed = placed.reshape(-1, 3)
        lo = np.minimum(placed.min(axis=0), -self.core_half) if len(placed) else -self.core_half
        hi = np.maximum(placed.max(axis=0), self.core_half) if len(placed) else self.core_half
        return np.stack([lo, hi])


def patch_box(gripper: GripperSpec, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) (3,) of the patch box in the gripper frame: the closing region, grown by PATCH_MARGIN
    along v and t and by PATCH_SUPPORT beyond the fingertips along u; it starts at the palm (u = 0)."""
    half_v, half_t = gripper.closing_width / 2 + PATCH_MARGIN, gripper.closing_height / 2 + PATCH_MARGIN
    return (np.array([0.0, -half_v, -half_t]),
            np.array([gripper.closing_depth + PATCH_SUPPORT, half_v, half_t]))


def grid_pitch(gripper: GripperSpec, resolution: float) -> tuple[float, float]:
    """Patch spacing along v and t: a neighbour's patch box must clear this patch's open fingers."""
    gap = resolution / 2
    lower, upper = patch_box(gripper, resolution)
    pitch_v = gripper.max_opening / 2 + gripper.finger_thickness + upper[1] + gap
    pitch_t = max(gripper.finger_height, gripper.closing_height) / 2 + upper[2] + gap
    return pitch_v, pitch_t


def layout_patches(plane: np.ndarray, gripper: GripperSpec, resolution: float) -> Layout:
    """Placements of U patches with plane classes (U,) int: each class on its face of the core box."""
    pitch = grid_pitch(gripper, resolution)
    cells = [_grid_cells(int(np.sum(plane == f)), pitch) for f in range(3)]
    core_half = _core_half(cells, pitch, resolution)
    lower, upper = patch_box(gripper, resolution)
    gap = resolution / 2
    placements = np.zeros((len(plane), 4, 4))
    for f, (normal, axis_v, axis_t) in enumerate(FACES):
        members = np.flatnonzero(plane == f)
        origin = normal * (core_half @ normal + upper[0] + gap)
        for k, cell in zip(members, cells[f], strict=True):
            centre = origin + cell[0] * axis_v + cell[1] * axis_t
            placements[k] = pose_from_axes(centre[None], -normal[None], axis_v[None])[0]
    return Layout(placements, np.asarray(plane, dtype=np.int8), core_half, pitch, np.stack([lower, upper]))


def _core_half(cells: list[np.ndarray], pitch: tuple[float, float], resolution: float) -> np.ndarray:
    """(3,) half extents of the core box: each face's grid (with half a pitch around it) must fit on it."""
    half = np.full(3, resolution)
    for (_, axis_v, axis_t), grid in zip(FACES, cells, strict=True):
        if len(grid):
            half = np.maximum(half, axis_v * (np.abs(grid[:, 0]).max() + pitch[0] / 2))
            half = np.maximum(half, axis_t * (np.abs(grid[:, 1]).max() + pitch[1] / 2))
    return half + resolution


def _grid_cells(count: int, pitch: tuple[float, float]) -> np.ndarray:
    """(count, 2) offsets (v, t) of a near-square grid of patches centred on the face."""
    if count == 0:
        return np.zeros((0, 2))
    cols = int(np.ceil(np.sqrt(count * pitch[1] / pitch[0])))
    rows = int(np.ceil(count / cols))
    j, i = np.divmod(np.arange(count), cols)
    return np.stack([(i - (cols - 1) / 2) * pitch[0], (j - (rows - 1) / 2) * pitch[1]], axis=1)


def cube_points(centres: np.ndarray, edge: float | np.ndarray, per_side: int = 3) -> np.ndarray:
    """(M * 6 * per_side^2, 3) points on the faces of axis-aligned boxes of edge (scalar or (3,)), a grid on
    each face."""
    g = (np.arange(per_side) + 0.5) / per_side - 0.5
    uu, vv = [x.ravel() for x in np.meshgrid(g, g)]
    faces = []
    for axis in range(3):
        for sign in (-0.5, 0.5):
            f = np.zeros((len(uu), 3))
            f[:, axis] = sign
            f[:, (axis + 1) % 3], f[:, (axis + 2) % 3] = uu, vv
            faces.append(f)
    offsets = np.vstack(faces) * edge
    return (centres[:, None, :] + offsets[None, :, :]).reshape(-1, 3)


def region_codes(points: np.ndarray, placements: np.ndarray, grid_shape: tuple[int, int, int],
                 resolution: float, index: PointGrid | None = None) -> np.ndarray:
    """Codes a gripper sees at each placement (U, 4, 4) in the one object's points (n, 3): the crop of
    :func:`core.voxel.crop_codes`, which looks only at points near each closing region (through ``index``, a
    :class:`PointGrid` of ``points``, when given). -> (U, B) uint8"""
    return crop_codes(points, placements, grid_shape, resolution, index=index)[0]


def placement_point_grid(points: np.ndarray, gripper: GripperSpec, grid_shape: tuple[int, int, int],
                         resolution: float) -> PointGrid:
    """One grid index of the one object's points (n, 3) for both checks of every placement
    (:func:`region_codes` and :func:`corridor_intrusions`): cells no wider than the thinnest box either queries,
    so the one sort of the points serves both."""
    closing = np.array(grid_shape, dtype=float) * resolution
    corridor = corridor_boxes(gripper, reach=1.0)
    return PointGrid(points, float(min(closing.min(), np.min(corridor[:, 1] - corridor[:, 0]))))


def corridor_boxes(gripper: GripperSpec, reach: float) -> np.ndarray:
    """(2, 2, 3) gripper-frame boxes (lower, upper) swept by the open gripper on its way in along +u: the palm
    path (u < 0, palm height) and the fingers with the closing region (0 <= u < finger_length)."""
    half_v = gripper.max_opening / 2 + gripper.finger_thickness
    palm_t = max(gripper.palm_height, gripper.finger_height) / 2
    finger_t = max(gripper.finger_height, gripper.closing_height) / 2
    return np.array([[[-reach, -half_v, -palm_t], [0.0, half_v, palm_t]],
                     [[0.0, -half_v, -finger_t], [gripper.finger_length, half_v, finger_t]]])


def corridor_intrusions(points: np.ndarray, owner: np.ndarray, placements: np.ndarray, gripper: GripperSpec,
                        reach: float, index: PointGrid | None = None) -> np.ndarray:
    """(U,) int64: points not of patch k (other patches, or the core with owner -1) inside the corridor of each
    placement k (:func:`corridor_boxes`); ``index``: a :class:`PointGrid` of ``points`` (built here if None)."""
    boxes = corridor_boxes(gripper, reach)
    if index is None:
        index = PointGrid(points, float(np.min(boxes[:, 1] - boxes[:, 0])))  # cells no wider than the thinnest box
    counts = np.zeros(len(placements), dtype=np.int64)
    for k, pose in enumerate(placements):
        for lower, upper in boxes:
            near = index.in_box(*posed_box_bounds(lower, upper, pose))
            local = to_gripper_frame(points[near], pose[None])[0]
            inside = np.all((local > lower) & (local < upper), axis=1)
            counts[k] += int(np.sum(inside & (owner[near] != k)))
    return counts


def box_arrays(centres: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangle meshes of axis-aligned boxes with edges (M, 3): vertices (8M, 3), faces (12M, 3) int64."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    tris = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    vertices = (centres[:, None, :] + corners[None] * np.asarray(edges, dtype=float)[:, None, :]).reshape(-1, 3)
    faces = (tris[None] + 8 * np.arange(len(centres))[:, None, None]).reshape(-1, 3)
    return vertices, faces


def assembly_geometry(layout: Layout, pieces: list[list[np.ndarray]], points: list[np.ndarray],
                      resolution: float) -> dict[str, np.ndarray]:
    """Mesh, dense points and owners of the whole object: every patch's convex pieces and surface points
    (patch frame) placed by its placement, and the core box.

    pieces : per patch, (k, 3) points of each convex piece; points : per patch, (m, 3) surface points
    returns : vertices (V, 3), faces (F, 3) int64, face_group (F,) int8 (plane class of the patch, 3 = core),
              piece_patch (K,) int64 patch of each placed piece, points (P, 3), point_patch (P,) int32 (-1 = core)
    """
    meshes, groups, owners = [], [], []
    for k, (patch_pieces, placement) in enumerate(zip(pieces, layout.placements, strict=True)):
        for piece in patch_pieces:
            vertices, faces = hull_mesh(transform_points(piece, placement))
            meshes.append((vertices, faces))
            groups.append(np.full(len(faces), layout.face[k], dtype=np.int8))
            owners.append(k)
    core_vertices, core_faces = box_arrays(np.zeros((1, 3)), 2 * layout.core_half[None])
    meshes.append((core_vertices, core_faces))
    groups.append(np.full(len(core_faces), 3, dtype=np.int8))
    vertices, faces = merge_meshes(meshes)
    per_side = max(2, int(np.ceil(2 * layout.core_half.max() / resolution)))
    core = cube_points(np.zeros((1, 3)), 2 * layout.core_half, per_side)
    placed, owner = placed_points(points, layout.placements, core)
    return {"vertices": vertices, "faces": faces, "face_group": np.concatenate(groups),
            "piece_patch": np.array(owners, dtype=np.int64), "points": placed, "point_patch": owner}


def placed_points(points: list[np.ndarray], placements: np.ndarray,
                   core: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every patch's points (m_k, 3) moved by its placement (U, 4, 4), then the core's, written into one array
    (the one object holds tens of millions of points: no list of copies). -> (P, 3) float64, (P,) int32 owner
    (patch index, -1 for the core)."""
    sizes = np.array([len(p) for p in points] + [len(core)], dtype=np.int64)
    out = np.empty((int(sizes.sum()), 3))
    owner = np.repeat(np.append(np.arange(len(points)), -1).astype(np.int32), sizes)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    for k, p in enumerate(points):
        out[starts[k]:starts[k + 1]] = transform_points(p, placements[k])
    out[starts[-2]:] = core
    return out, owner
