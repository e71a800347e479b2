"""Per-object extraction: load, sample candidates, crop codes, write one committed part.

Runs inside a worker. It reads only the frozen :class:`JobSpec` and the object reference, writes only its own
part, and returns a small :class:`ObjectResult` (no large arrays travel back).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from onepiece_dist.core.closure import binary_label, closure_arrays
from onepiece_dist.core.mesh import TriangleMesh, enclosed_volume, sample_surface
from onepiece_dist.core.sampling import GraspCandidates, object_rng, sample_candidates
from onepiece_dist.core.voxel import crop_regions, network_inputs, stored_codes
from onepiece_dist.errors import MeshRejected
from onepiece_dist.job.results import ObjectPartMeta, ObjectResult, part_key
from onepiece_dist.objects import ObjectRef, load_object
from onepiece_dist.objects.foreign import read_foreign_grasps
from onepiece_dist.plan.observation import Observation
from onepiece_dist.plan.planner import propose
from onepiece_dist.plan.scorer import CropRecord
from onepiece_dist.sim.collision import convex_pieces
from onepiece_dist.sim.views import camera_for_grasps, object_views
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.specs.plan import PlanSpec
from onepiece_dist.store import PartStore
from onepiece_dist.store.format import grasp_arrays


def extract_object(spec: JobSpec, ref: ObjectRef, index: int, parts: PartStore) -> ObjectResult:
    """Extract one object into ``parts``; a bad object becomes a rejected result, never an exception."""
    start = time.perf_counter()
    try:
        loaded = load_object(ref, spec)
    except MeshRejected as err:
        return ObjectResult(index, ref.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    key, repairs = part_key(loaded.content_id, spec.result_key()), "; ".join(loaded.repairs)
    if parts.is_committed(key):
        meta = ObjectPartMeta.from_attrs(parts.read_meta(key))
        return replace(_from_meta(index, ref.name, key, meta, reused=True, start=start), repairs=repairs,
                       shortfall=shortfall(meta, spec.grasps_per_object))
    try:
        arrays, meta = extract_arrays(spec, loaded.mesh, spec.decompositions_folder(), loaded)
    except MeshRejected as err:
        return ObjectResult(index, ref.name, "rejected", reason=err.reason, content_id=loaded.content_id,
                            seconds=time.perf_counter() - start)
    except (ArithmeticError, ValueError, RuntimeError) as err:  # numerical trouble in one object stays there
        return ObjectResult(index, ref.name, "rejected", reason=f"extraction failed: {type(err).__name__}: {err}",
                            content_id=loaded.content_id, seconds=time.perf_counter() - start)
    parts.write(key, arrays, {"name": ref.name, "content_id": loaded.content_id, **meta,
                              "made_seconds": time.perf_counter() - start})
    meta = ObjectPartMeta.from_attrs(parts.read_meta(key))
    return replace(_from_meta(index, ref.name, key, meta, reused=False, start=start), repairs=repairs,
                   shortfall=shortfall(meta, spec.grasps_per_object))


def extract_arrays(spec: JobSpec, mesh: TriangleMesh, collision_dir: Path,
                   loaded=None) -> tuple[dict[str, np.ndarray], dict]:
    """Candidates, their simulated settled poses and the codes cropped there; empty crops dropped. ``loaded`` (a
    LoadedObject) carries a folder manifest's density and friction (None: the job's)."""
    rng = object_rng(mesh.content_id, spec.seed)
    points, normals = sample_surface(mesh, spec.sampler.surface_points, rng)
    views = _render_views(spec, mesh)
    given = loaded is not None and bool(loaded.ref.grasps)
    if given:
        cands, sampled_on = given_candidates(spec, loaded.ref), None
    elif spec.views.sampling == "view":
        cands, sampled_on = view_candidates(spec, views, rng)
    else:
        cands, sampled_on = sample_candidates(mesh, points, normals, spec.grasps_per_object, spec.gripper,
                                              spec.sampler, rng), None
    if len(cands.poses) == 0:
        raise MeshRejected(mesh.name, f"no collision-free {_sampler_name(spec)} grasp narrower than max_opening="
                                      f"{spec.gripper.max_opening} m among {cands.tried} tried: "
                                      "the object cannot fit the gripper")
    pieces = _collision_pieces(spec, mesh, collision_dir)
    volume = enclosed_volume(mesh)
    physics = (loaded.density(spec.sim.density, volume), loaded.friction) if loaded else (spec.sim.density, 1.0)
    grasps, meta, held = _simulate(spec, mesh, cands, pieces, physics)
    clouds, source = crop_sources(spec, points, views, grasps["pose"],
                                  None if sampled_on is None else sampled_on[held])
    grid, res = spec.grid_shape(), spec.voxel.resolution
    codes, counts, inside = crop_codes_from(clouds, source, grasps["pose"], grid, res, keep_points=True)
    planned = spec.views.sampling == "view"  # the network scores what the camera shows before the fingers close
    static, static_counts, seen = crop_codes_from(clouds, source, grasps["candidate_pose"], grid, res, planned)
    keep = counts > 0
    if planned:
        keep &= static_counts > 0
        inside = seen
    grasps = {name: value[keep] for name, value in grasps.items()}
    kept = [inside[i] for i in np.flatnonzero(keep)]
    codes, crop_points = network_inputs(codes[keep], kept, grid, spec.voxel.canonical, spec.sim.points_per_grasp, rng)
    static = stored_codes(static[keep], grid, spec.voxel.canonical)
    arrays = grasp_arrays({**grasps, "code": codes, "candidate_code": static})
    if given:  # which of the file's grasps each kept one is (the rest did not hold: our label says fail)
        arrays["source_row"] = grasp_arrays({"source_row": np.flatnonzero(held)[keep]})["source_row"]
    if crop_points is not None:
        arrays["points"] = crop_points
    if spec.closure.enabled:
        arrays.update(closure_labelled(spec, mesh.vertices, mesh.faces, grasps["pose"], arrays.get("success")))
    if views is not None:
        arrays.update({"view_camera": views.cameras, "view_points": views.points, "view_of_point": views.point_view})
    arrays.update({"object_surface": points, "object_piece_vertices": np.vstack(pieces),  # patches are cut from these
                   "object_piece_sizes": np.array([len(p) for p in pieces], dtype=np.int64)})
    meta.update({"grasps": int(keep.sum()), "empty_crops": int((~keep).sum()), "candidates_tried": cands.tried,
                 "volume": volume, "density": physics[0], "friction": physics[1],
                 "collisions": cands.rejected_collision,
                 "settled_code_differs": int(np.any(codes != static, axis=1).sum())})
    return arrays, meta


def closure_labelled(spec: JobSpec, vertices: np.ndarray, faces: np.ndarray, poses: np.ndarray,
                     physics: np.ndarray | None) -> dict[str, np.ndarray]:
    """The closure arrays of grasps at ``poses`` on the mesh, and, when ``closure.label`` is not physics, their
    binary label as success with the trials' outcome (if any) as physics_success."""
    arrays = closure_arrays(vertices, faces, poses, spec)
    if spec.closure.label != "physics":
        if physics is not None:
            arrays["physics_success"] = physics
        arrays["success"] = binary_label(spec.closure, physics, arrays["fc_mu"])
    return grasp_arrays(arrays)


def _collision_pieces(spec: JobSpec, mesh: TriangleMesh, collision_dir: Path) -> list[np.ndarray]:
    """The object's convex pieces as the simulation uses them (cached per content id)."""
    return convex_pieces(mesh, collision_dir, spec.sim.collision)


def given_candidates(spec: JobSpec, ref: ObjectRef) -> GraspCandidates:
    """The grasps of the object's grasp file (objects.foreign) in our frame for the job's gripper, fingers open."""
    found = read_foreign_grasps(ref.grasps)
    if found.digest != ref.grasps_digest:
        raise MeshRejected(ref.name, f"{ref.grasps} changed while the job ran: run it again")
    poses = found.poses(spec.gripper.finger_length)
    return GraspCandidates(poses, np.full(len(poses), spec.gripper.max_opening), len(poses), 0)


def _sampler_name(spec: JobSpec) -> str:
    return "view-sampled" if spec.views.sampling == "view" else spec.sampler.method


def view_candidates(spec: JobSpec, views, rng: np.random.Generator) -> tuple[GraspCandidates, np.ndarray]:
    """Candidates as the planner samples a camera's cloud (plan.planner.propose: GPD-style placements, at least
    its min_points observed points in the closing region), ``ceil(grasps_per_object / views)`` on each view's
    cloud; and (n,) int64 the view each was sampled on (its crop's cloud)."""
    record = CropRecord(spec.gripper, spec.voxel, spec.sim.points_per_grasp, spec.train.model)
    per_view = -(-spec.grasps_per_object // len(views.cameras))
    plan = PlanSpec(candidates=per_view, support_plane="none", top_down=False)
    poses, sampled_on, tried = [], [], 0
    for k, camera in enumerate(views.cameras.astype(np.float64)):
        cloud = views.cloud(k).astype(np.float64)
        if len(cloud) < 50:
            continue
        found = propose(Observation(cloud, camera[:3, 3], f"view {k}"), record, plan, rng)
        poses.append(found.poses)
        sampled_on.append(np.full(len(found.poses), k, dtype=np.int64))
        tried += found.counts.sampled
    poses = np.concatenate(poses) if poses else np.zeros((0, 4, 4))
    widths = np.full(len(poses), spec.gripper.max_opening)
    return (GraspCandidates(poses, widths, tried, tried - len(poses)),
            np.concatenate(sampled_on) if sampled_on else np.zeros(0, dtype=np.int64))


def _simulate(spec: JobSpec, mesh: TriangleMesh, cands: GraspCandidates, pieces: list[np.ndarray],
              physics: tuple[float, float] | None = None) -> tuple[dict[str, np.ndarray], dict, np.ndarray]:
    """Run the extract (and label) protocol; keep the trials whose fingers hold the object (and say which: the
    (n,) bool mask over the candidates)."""
    if not spec.sim.physics:
        return ({"pose": cands.poses, "candidate_pose": cands.poses, "width": cands.widths}, {"trials": 0},
                np.ones(len(cands.poses), dtype=bool))
    from onepiece_dist.sim.trials import OUTCOMES, LabelNoise, run_trials
    from onepiece_dist.sim.world import process_world

    world = process_world(spec.gripper)
    density, friction = physics or (spec.sim.density, 1.0)
    world.load_object(pieces, enclosed_volume(mesh), density, friction)
    noise = LabelNoise.from_spec(spec.sim)
    batch = run_trials(world, cands.poses, label=spec.sim.label, noise=noise,
                       rng=object_rng(mesh.content_id, spec.seed, stream=1))
    ok = batch.outcome == 0
    if spec.views.sampling == "view":  # the planner meets candidates whose fingers close on nothing: keep them
        ok |= batch.outcome == OUTCOMES.index("no_contact")  # as what they are (labelled: never a success)
    width = np.where(np.isfinite(batch.width), batch.width, 0.0)  # no contact: the fingers closed fully
    grasps = {"pose": batch.settled_pose[ok], "candidate_pose": cands.poses[ok], "width": width[ok],
              "shift": batch.shift[ok]}
    if batch.success is not None:
        grasps["success"] = batch.success[ok].astype(np.uint8)
        grasps["quality"] = batch.quality[ok]
        grasps["slip"] = batch.slip[ok]
    dropped = {f"dropped_{name}": int(np.sum(batch.outcome == k)) for k, name in enumerate(OUTCOMES) if k}
    return grasps, {"trials": len(cands.poses), **dropped}, ok


def _render_views(spec: JobSpec, mesh: TriangleMesh):
    """The object's depth views (sim.views.ObjectViews), or None when the spec asks for none."""
    if not spec.views.count:
        return None

    views = spec.views
    return object_views(mesh.vertices, mesh.faces, views.count, views.image_size, views.fov_deg, views.distance)


def crop_sources(spec: JobSpec, points: np.ndarray, views, poses: np.ndarray,
                 sampled_on: np.ndarray | None = None) -> tuple[list[np.ndarray], np.ndarray]:
    """The clouds grasps are cropped from, and (N,) int64 which one per pose: the full surface (n, 3) for all, or
    with ``views.crop='partial'`` the depth view each grasp was sampled on (``sampled_on``, view sampling), else
    the view of the camera nearest its approach direction."""
    if views is None or spec.views.crop == "full":
        return [points], np.zeros(len(poses), dtype=np.int64)

    source = camera_for_grasps(views.cameras, poses) if sampled_on is None else sampled_on
    return [views.cloud(k) for k in range(len(views.cameras))], source


def crop_codes_from(clouds: list[np.ndarray], source: np.ndarray, poses: np.ndarray, grid: tuple[int, int, int],
                    resolution: float, keep_points: bool = False):
    """crop_regions with pose i cropped from ``clouds[source[i]]``; poses of one cloud are cropped together.
    -> codes (N, B) uint8, counts (N,) int64, and with ``keep_points`` each pose's inside points (else None)."""
    codes = np.zeros((len(poses), (int(np.prod(grid)) + 7) // 8), dtype=np.uint8)
    counts = np.zeros(len(poses), dtype=np.int64)
    inside: list = [None] * len(poses)
    for k in np.unique(source):
        rows = np.flatnonzero(source == k)
        codes[rows], counts[rows], found = crop_regions(clouds[k], poses[rows], grid, resolution, keep_points)
        for row, points in zip(rows, found or [], strict=False):
            inside[row] = points
    return codes, counts, inside if keep_points else None


def shortfall(meta: ObjectPartMeta, asked: int) -> str:
    """Why an object kept fewer than half the grasps asked for, from its part's counts ('' when it kept enough):
    candidates whose open gripper met the object, whose fingers started in it or closed on nothing, that flew off,
    or whose crop held no point."""
    kept = int(meta.grasps)
    if kept >= asked / 2:
        return ""
    causes = [(meta.collisions, "met the object with the open gripper while sampled"),
              (meta.dropped_start_collision, "started in collision"),
              (meta.dropped_no_contact, "closed on nothing (too wide, or the object slipped out)"),
              (meta.dropped_invalid, "sent the object flying"),
              (meta.empty_crops, "held no surface point in the closing region")]
    said = [f"{n} {what}" for n, what in sorted(causes, key=lambda c: -c[0]) if n]
    return f"{kept} of {asked} grasps kept: " + ("; ".join(said) if said else "too few candidates could be sampled")


def _from_meta(index: int, name: str, key: str, meta: ObjectPartMeta, reused: bool, start: float) -> ObjectResult:
    made = meta.made_seconds if meta.made_seconds is not None else time.perf_counter() - start
    return ObjectResult(index, name, "ok", content_id=meta.content_id, part_key=key, grasps=meta.grasps,
                        empty_crops=meta.empty_crops, candidates_tried=meta.candidates_tried,
                        collisions=meta.collisions, settled_code_differs=meta.settled_code_differs,
                        reused=reused, seconds=time.perf_counter() - start, made_seconds=float(made))
