"""Label transfer: how far a label computed once for a shape holds for the other grasps that share its code (the
method's premise, measured; docs/assembly.md).

For a seeded sample of unique codes with at least two source grasps, the representative and up to
``sim.transfer_grasps - 1`` other grasps of each code are labelled on their own source objects with the label
protocol (at their candidate poses, as labelling every candidate would). Reported, as agreement of success and
Pearson correlation of quality over pairs:
(a) each patch's label at its placement on the one object against its representative's on the source object
    (what clipping and the patch's mass rule change);
(b) the representative against the other grasps of its code (how much the code alone decides the label);
(c) random pairs of the labelled grasps with different codes (the floor).
Success is the job's label (``closure.label``): with force closure, the sources' grasps are scored at their
settled poses on their convex pieces, as the patches are; quality stays the trials' success fraction.
"""

from __future__ import annotations

import numpy as np

from onepiece_dist.core.clip import pieces_mesh
from onepiece_dist.core.sampling import object_rng
from onepiece_dist.job.patches import source_geometry
from onepiece_dist.job.stages.extract import closure_labelled
from onepiece_dist.job.status import PairAgreement, TransferReport
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import DatasetReader, PartStore


def measure_transfer(spec: JobSpec, reader: DatasetReader, parts: PartStore) -> TransferReport:
    """Label the sampled source grasps and compare (a), (b), (c)."""
    groups = sample_code_groups(reader, spec.sim.transfer_codes, spec.sim.transfer_grasps, spec.seed)
    rows = np.concatenate(groups) if groups else np.zeros(0, dtype=np.int64)
    success, quality = label_on_sources(spec, reader, parts, rows)
    label = dict(zip(rows.tolist(), zip(success, quality, strict=True), strict=True))
    patch = patch_labels(reader)
    codes = reader["grasps/code_index"][rows] if len(rows) else np.zeros(0, dtype=np.int64)
    a = [(patch.get(int(c), (0.0, 0.0)), label[int(g[0])]) for g, c in zip(groups, codes[_firsts(groups)],
                                                                          strict=True)]
    b = [(label[int(g[0])], label[int(other)]) for g in groups for other in g[1:]]
    return TransferReport(codes=len(groups), grasps_labelled=int(len(rows)),
                          label_trials=int(len(rows) * spec.sim.label_trials),
                          patch_vs_source=agreement(a), same_code=agreement(b),
                          random_pairs=agreement(random_pairs(rows, codes, label, len(b) or len(a), spec.seed)))


def _firsts(groups: list[np.ndarray]) -> np.ndarray:
    return np.cumsum([0] + [len(g) for g in groups])[:-1].astype(np.int64)


def sample_code_groups(reader: DatasetReader, codes: int, per_code: int, seed: int) -> list[np.ndarray]:
    """For up to ``codes`` unique codes with two or more grasps (a seeded sample, in code order), their
    representative first, then up to ``per_code - 1`` other grasps (lowest rows)."""
    counts, representative = reader["unique/count"], reader["unique/representative"]
    eligible = np.flatnonzero(counts >= 2)
    rng = np.random.default_rng([seed, 7])
    chosen = np.sort(rng.permutation(eligible)[:codes])
    code_index = reader["grasps/code_index"]
    groups = []
    for k in chosen:
        others = np.flatnonzero(code_index == k)
        others = others[others != representative[k]][: per_code - 1]
        groups.append(np.concatenate([[representative[k]], others]).astype(np.int64))
    return groups


def label_on_sources(spec: JobSpec, reader: DatasetReader, parts: PartStore,
                     rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Success (0/1) and quality of the label protocol at the candidate pose of each grasp row, on its source."""
    from onepiece_dist.sim.trials import LabelNoise, run_trials
    from onepiece_dist.sim.world import process_world

    success, quality = np.zeros(len(rows)), np.zeros(len(rows))
    if not len(rows):
        return success, quality
    objects = reader["grasps/object"][rows]
    poses = reader.array("grasps/candidate_pose").oindex[np.sort(rows)].astype(np.float64)
    poses = poses[np.argsort(np.argsort(rows))]
    content_ids = [bytes(row).hex() for row in reader["objects/id"]]
    world, noise = process_world(spec.gripper), LabelNoise.from_spec(spec.sim)
    for obj in np.unique(objects):
        source = source_geometry(reader, parts, int(obj))
        density = spec.sim.density if source.density is None else source.density  # a manifest's, if any
        world.load_object(source.pieces, source.volume, density, source.friction)
        mine = np.flatnonzero(objects == obj)
        batch = run_trials(world, poses[mine], label=True, noise=noise,
                           rng=object_rng(content_ids[obj], spec.seed, stream=3))
        held = batch.outcome == 0
        success[mine] = np.where(held, protocol_label(spec, source.pieces, batch), False)
        quality[mine] = np.where(held, batch.quality, 0.0)
    return success, quality


def protocol_label(spec: JobSpec, pieces: list[np.ndarray], batch) -> np.ndarray:
    """The trials' binary label under ``closure.label``: their outcome, or force closure (with "both": and the
    outcome) at the settled poses on the source's convex pieces, the geometry a patch is scored on."""
    if spec.closure.label == "physics":
        return batch.success

    vertices, faces = pieces_mesh(pieces)
    return closure_labelled(spec, vertices, faces, batch.settled_pose, batch.success)["success"]


def patch_labels(reader: DatasetReader) -> dict[int, tuple[float, float]]:
    """Patch -> (success, quality) of its label at the placement itself (the first trial of each patch; a patch
    whose grasp at the placement was not held counts as a failure)."""
    if not reader.has("assembled/grasps/patch"):
        return {}
    patch = reader["assembled/grasps/patch"]
    candidate = reader["assembled/grasps/candidate_pose"].astype(np.float64)
    placement = reader["assembled/placement"].astype(np.float64)
    at_placement = np.all(np.isclose(candidate, placement[patch], atol=1e-6), axis=(1, 2))
    success, quality = reader["assembled/grasps/success"], reader["assembled/grasps/quality"]
    return {int(k): (float(success[i]), float(quality[i])) for i, k in enumerate(patch) if at_placement[i]}


def random_pairs(rows: np.ndarray, codes: np.ndarray, label: dict, count: int,
                 seed: int) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """``count`` seeded random pairs of labelled grasps whose codes differ."""
    rng = np.random.default_rng([seed, 8])
    pairs = []
    for _ in range(20 * max(count, 1)):
        if len(pairs) >= count or len(rows) < 2:
            break
        i, j = rng.choice(len(rows), 2, replace=False)
        if codes[i] != codes[j]:
            pairs.append((label[int(rows[i])], label[int(rows[j])]))
    return pairs


def agreement(pairs: list[tuple[tuple[float, float], tuple[float, float]]]) -> PairAgreement:
    """Success agreement and quality correlation over pairs of (success, quality) labels."""
    if not pairs:
        return PairAgreement(pairs=0, success_agreement=None, quality_correlation=None)
    values = np.array([[a[0], b[0], a[1], b[1]] for a, b in pairs], dtype=np.float64)
    agree = float(np.mean((values[:, 0] > 0.5) == (values[:, 1] > 0.5)))
    spread = values[:, 2].std() > 0 and values[:, 3].std() > 0
    corr = float(np.corrcoef(values[:, 2], values[:, 3])[0, 1]) if spread else None
    return PairAgreement(pairs=len(pairs), success_agreement=round(agree, 4),
                         quality_correlation=None if corr is None else round(corr, 4))
