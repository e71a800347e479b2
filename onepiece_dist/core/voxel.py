"""Voxel codes: the occupancy of the closing region at the network's resolution, packed into bits.

Bit order (the dataset contract): occupancy ``occ`` of shape (a, b, c) over (u, v, t), voxel (i, j, k)
covering u in [i r, (i+1) r), v in [-W/2 + j r, ...), t in [-H/2 + k r, ...). The flat index is
``f = (i * b + j) * c + k`` (C order) and lives in byte ``f // 8`` at bit ``7 - f % 8``
(``np.packbits`` with ``bitorder="big"``). A code has ``B = ceil(a b c / 8)`` bytes; padding bits are 0.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.frames import closing_region_bounds, gripper_frame_batches, to_gripper_frame
from onepiece_dist.core.mesh import resample_crops
from onepiece_dist.core.spatial import PointGrid, posed_box_bounds


def pack_codes(occupancy: np.ndarray) -> np.ndarray:
    """occupancy : (n, a, b, c) bool -> (n, B) uint8."""
    flat = occupancy.reshape(len(occupancy), -1)
    return np.packbits(flat, axis=1, bitorder="big")


def unpack_codes(codes: np.ndarray, grid_shape: tuple[int, int, int]) -> np.ndarray:
    """codes : (n, B) uint8 -> (n, a, b, c) bool."""
    nbits = int(np.prod(grid_shape))
    bits = np.unpackbits(codes, axis=1, count=nbits, bitorder="big")
    return bits.reshape((len(codes), *grid_shape)).astype(bool)


def canonical_codes(codes: np.ndarray, grid_shape: tuple[int, int, int]) -> np.ndarray:
    """Canonical form under the 180-degree turn about u, (v, t) -> (-v, -t).

    Of a code and its turned twin, the one whose bytes compare smaller is kept.
    codes : (n, B) uint8 -> (n, B) uint8
    """
    return bytewise_smaller(codes, pack_codes(unpack_codes(codes, grid_shape)[:, :, ::-1, ::-1]))


def network_inputs(codes: np.ndarray, inside: list[np.ndarray], grid_shape: tuple[int, int, int], canonical: bool,
                   points_per_grasp: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray | None]:
    """The network's inputs of crops cut by :func:`crop_regions`, one recipe for the job's extraction, its label
    stage and the planner: the codes (canonical when the voxel spec asks) and each crop's points ``inside``
    resampled to P = ``points_per_grasp`` (n, P, 3) float16, drawn from ``rng`` in crop order (an empty crop draws
    nothing; P = 0: no points, None, and nothing drawn). -> codes (n, B) uint8, points."""
    points = resample_crops(inside, points_per_grasp, rng) if points_per_grasp > 0 else None
    return stored_codes(codes, grid_shape, canonical), points


def stored_codes(codes: np.ndarray, grid_shape: tuple[int, int, int], canonical: bool) -> np.ndarray:
    """``codes`` as a dataset stores them and a network reads them: canonical when the voxel spec asks."""
    return canonical_codes(codes, grid_shape) if canonical else codes


def bytewise_smaller(codes: np.ndarray, twins: np.ndarray) -> np.ndarray:
    """Row by row, whichever of ``codes`` and ``twins`` compares smaller byte by byte (lexicographic order).

    codes, twins : (n, B) uint8 -> (n, B) uint8
    """
    differs = codes != twins
    first = np.argmax(differs, axis=1)
    rows = np.arange(len(codes))
    twin_smaller = differs.any(axis=1) & (twins[rows, first] < codes[rows, first])
    return np.where(twin_smaller[:, None], twins, codes)


def voxel_indices(points_g: np.ndarray, grid_shape: tuple[int, int, int], resolution: float) -> np.ndarray:
    """Flat voxel index of gripper-frame points, -1 for points outside the closing region.

    points_g : (..., 3) float -> (...) int64
    """
    a, b, c = grid_shape
    lower, upper = closing_region_bounds(a * resolution, b * resolution, c * resolution)
    ijk = np.floor((points_g - lower) / resolution).astype(np.int64)
    inside = np.all((points_g >= lower) & (points_g < upper), axis=-1)
    ijk = np.clip(ijk, 0, np.array([a - 1, b - 1, c - 1]))
    flat = (ijk[..., 0] * b + ijk[..., 1]) * c + ijk[..., 2]
    return np.where(inside, flat, -1)


DENSE_POINTS = 50_000  # clouds up to this size are cropped for a whole batch of poses in one matrix product


def crop_codes(points: np.ndarray, poses: np.ndarray, grid_shape: tuple[int, int, int],
               resolution: float, index: PointGrid | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Voxel codes of an object's surface points seen from many gripper poses.

    points : (m, 3) float   object-frame surface points
    poses : (n, 4, 4) float gripper poses in the object frame
    index : a :class:`PointGrid` of ``points`` already built (any cell size), or None
    returns : codes (n, B) uint8, counts (n,) int64 points inside each closing region
    """
    codes, counts, _ = crop_regions(points, poses, grid_shape, resolution, index=index)
    return codes, counts


def crop_regions(points: np.ndarray, poses: np.ndarray, grid_shape: tuple[int, int, int], resolution: float,
                 keep_points: bool = False, index: PointGrid | None = None
                 ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray] | None]:
    """:func:`crop_codes`, and with ``keep_points`` the gripper-frame points inside each pose's closing region
    ((k_i, 3) float64 per pose, in point order, as :func:`crop_points` gives them). Clouds of up to DENSE_POINTS
    points are transformed for a batch of poses at once; larger ones (the one object), or any cloud whose grid
    ``index`` is given, through a grid index, so each pose costs what is near it."""
    nvox = int(np.prod(grid_shape))
    occupancy = np.zeros((len(poses), nvox), dtype=bool)
    counts = np.zeros(len(poses), dtype=np.int64)
    kept: list[np.ndarray] | None = [] if keep_points else None
    if index is None and len(points) <= DENSE_POINTS:
        regions = _dense_regions(points, poses, grid_shape, resolution)
    else:
        regions = _indexed_regions(points, poses, grid_shape, resolution, index)
    for rows, inside in regions:  # rows (q,) pose of each inside point, in pose then point order
        flat = voxel_indices(inside, grid_shape, resolution)
        occupancy[rows, flat] = True
        counts += np.bincount(rows, minlength=len(poses))
        if kept is not None:
            kept.append(inside)
    if kept is not None:
        stacked = np.concatenate(kept) if kept else np.zeros((0, 3))
        kept = np.split(stacked, np.cumsum(counts)[:-1])
    return np.packbits(occupancy, axis=1, bitorder="big"), counts, kept


def _dense_regions(points: np.ndarray, poses: np.ndarray, grid_shape: tuple[int, int, int], resolution: float):
    """(rows, inside points) per batch of poses: every point transformed, those in the closing region kept."""
    a, b, c = grid_shape
    lower, upper = closing_region_bounds(a * resolution, b * resolution, c * resolution)
    for start, (u, v, t) in gripper_frame_batches(points, poses):
        slab = t >= lower[2]  # the region is thin along t: test it first, then the rest on the few that pass
        slab &= t < upper[2]
        pairs = np.flatnonzero(slab)  # pose-major, so pose then point order
        u, v, t = u.ravel()[pairs], v.ravel()[pairs], t.ravel()[pairs]
        inside = (u >= lower[0]) & (u < upper[0]) & (v >= lower[1]) & (v < upper[1])
        pairs = pairs[inside]
        yield start + pairs // len(points), np.stack([u[inside], v[inside], t[inside]], axis=1)


def _indexed_regions(points: np.ndarray, poses: np.ndarray, grid_shape: tuple[int, int, int], resolution: float,
                     index: PointGrid | None = None):
    """(rows, inside points) per pose, from the points near each posed closing region."""
    for k, near in enumerate(_points_near_regions(points, poses, grid_shape, resolution, index)):
        inside = near[voxel_indices(near, grid_shape, resolution) >= 0]
        yield np.full(len(inside), k, dtype=np.int64), inside


def _points_near_regions(points: np.ndarray, poses: np.ndarray, grid_shape: tuple[int, int, int],
                         resolution: float, index: PointGrid | None = None):
    """For each pose, the gripper-frame points that lie in the posed closing region's bounding box (a grid
    index, so each pose costs what is near it; built here unless given): (k, 3) float64 per pose, in pose
    order."""
    a, b, c = grid_shape
    lower, upper = closing_region_bounds(a * resolution, b * resolution, c * resolution)
    if index is None:
        index = PointGrid(points, float(np.min(upper - lower)))  # cells no wider than the region is thin
    for pose in poses:
        near = points[np.sort(index.in_box(*posed_box_bounds(lower, upper, pose)))]  # in point order
        yield to_gripper_frame(near, pose[None])[0]


def crop_points(points: np.ndarray, pose: np.ndarray, grid_shape: tuple[int, int, int],
                resolution: float) -> np.ndarray:
    """Gripper-frame points of one pose that fall inside the closing region. -> (k, 3) float64."""
    points_g = to_gripper_frame(points, pose[None])[0]
    return points_g[voxel_indices(points_g, grid_shape, resolution) >= 0]
