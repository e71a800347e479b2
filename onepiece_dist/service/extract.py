"""Per-object extraction: load, sample candidates, crop codes, write one committed part.

Runs inside a worker. It reads only the frozen :class:`JobSpec` and the object reference, writes only its own
part, and returns a small :class:`ObjectResult` (no large arrays travel back).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from onepiece_dist.core.mesh import sample_surface
from onepiece_dist.core.sampling import object_rng, sample_candidates
from onepiece_dist.core.voxel import canonical_codes, crop_codes
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, load_object
from onepiece_dist.spec import JobSpec
from onepiece_dist.store import PartStore


@dataclass(frozen=True)
class ObjectResult:
    """Summary of one object's extraction; ``status`` is 'ok' or 'rejected' (with ``reason``)."""

    index: int
    name: str
    status: str
    reason: str = ""
    content_id: str = ""
    part_key: str = ""
    grasps: int = 0
    empty_crops: int = 0
    candidates_tried: int = 0
    collisions: int = 0
    reused: bool = False
    seconds: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


def extract_object(spec: JobSpec, ref: ObjectRef, index: int, parts: PartStore) -> ObjectResult:
    """Extract one object into ``parts``; a bad object becomes a rejected result, never an exception."""
    start = time.perf_counter()
    try:
        loaded = load_object(ref, spec)
    except MeshRejected as err:
        return ObjectResult(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    key = f"{loaded.content_id}-{spec.result_key()}"
    if parts.is_committed(key):
        return _from_meta(index, ref.name, key, parts.read_meta(key), reused=True, start=start)
    try:
        arrays, meta = extract_arrays(spec, loaded.mesh)
    except MeshRejected as err:
        return ObjectResult(index, ref.name, "rejected", reason=err.reason, content_id=loaded.content_id,
                            seconds=time.perf_counter() - start)
    parts.write(key, arrays, {"name": ref.name, "content_id": loaded.content_id, **meta})
    return _from_meta(index, ref.name, key, parts.read_meta(key), reused=False, start=start)


def extract_arrays(spec: JobSpec, mesh) -> tuple[dict[str, np.ndarray], dict]:
    """Candidates and their codes at the candidate pose, empty crops dropped."""
    rng = object_rng(mesh.content_id, spec.seed)
    points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    cands = sample_candidates(mesh, points, normals, spec.grasps_per_object, spec.gripper, spec.sampler, rng)
    if len(cands.poses) == 0:
        raise MeshRejected(mesh.name, f"no collision-free antipodal grasp narrower than max_opening="
                                      f"{spec.gripper.max_opening} m among {cands.tried} tried: "
                                      "the object cannot fit the gripper")
    codes, counts = crop_codes(points, cands.poses, spec.grid_shape(), spec.voxel.resolution)
    keep = counts > 0
    codes = canonical_codes(codes[keep], spec.grid_shape()) if spec.voxel.canonical else codes[keep]
    arrays = {"pose": cands.poses[keep].astype(np.float32), "candidate_pose": cands.poses[keep].astype(np.float32),
              "width": cands.widths[keep].astype(np.float32), "code": codes}
    meta = {"grasps": int(keep.sum()), "empty_crops": int((~keep).sum()),
            "candidates_tried": cands.tried, "collisions": cands.rejected_collision}
    return arrays, meta


def _from_meta(index: int, name: str, key: str, meta: dict, reused: bool, start: float) -> ObjectResult:
    return ObjectResult(index, name, "ok", content_id=meta["content_id"], part_key=key, grasps=meta["grasps"],
                        empty_crops=meta["empty_crops"], candidates_tried=meta["candidates_tried"],
                        collisions=meta["collisions"], reused=reused, seconds=time.perf_counter() - start)
