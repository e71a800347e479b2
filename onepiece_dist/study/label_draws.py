"""The label drawn again on a held-out dataset, for its own ceiling (stats.ceiling): a seeded sample of its candidates,
each several times, every draw a new execution of the job's label protocol (sim.trials.label_draws).

Runs where it is called, its simulation in a pinned process (runtime.pinned_child): one object at a time, each
grasp's draws from its own generator ([seed, row]), so the draws do not depend on the sample's order or size.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, load_object, resolve_source
from onepiece_dist.runtime.pinned_child import PinnedSimulation
from onepiece_dist.sim.collision import load_simulated
from onepiece_dist.specs.job import JobSpec


def sample_rows(count: int, sample: int, seed: int) -> np.ndarray:
    """(min(sample, count),) sorted rows of a dataset's ``count`` grasps, seeded."""
    rng = np.random.default_rng([seed, 0x5EED])
    return np.sort(rng.choice(count, size=min(sample, count), replace=False))


def object_draws(job: JobSpec, ref: ObjectRef, poses: np.ndarray, rows: np.ndarray, draws: int, seed: int,
                 collision_dir: str) -> np.ndarray:
    """(n, draws) bool: ``draws`` fresh labels of each candidate ``poses`` (n, 4, 4) of the object ``ref``."""
    from onepiece_dist.sim.trials import LabelNoise, label_draws
    from onepiece_dist.sim.world import process_world

    world = process_world(job.gripper)
    load_simulated(world, load_object(ref, job), Path(collision_dir), job.sim.collision, job.sim.density)
    rngs = [np.random.default_rng([seed, int(row)]) for row in rows]
    return label_draws(world, poses, rngs, LabelNoise.from_spec(job.sim), draws)


def heldout_label_draws(job: JobSpec, dataset: str, sample: int, draws: int, seed: int) -> tuple[np.ndarray,
                                                                                                 np.ndarray]:
    """A seeded sample of the rows of ``job``'s dataset at ``dataset`` (its objects matched to ``job.objects`` by
    content id), and (rows, draws) bool: each one's label drawn ``draws`` times again by ``job``'s protocol."""
    from onepiece_dist.store import open_dataset

    reader = open_dataset(dataset)
    owner = reader["grasps/object"].astype(np.int64)
    rows = sample_rows(len(owner), sample, seed)
    poses = reader["grasps/candidate_pose"][...].astype(np.float64)
    ids = [bytes(row).hex() for row in reader["objects/id"]]
    refs = _refs_by_content_id(job)
    simulate, found = PinnedSimulation(), []
    try:
        for k in np.unique(owner[rows]):
            mine = rows[owner[rows] == k]
            found.append(simulate(object_draws, job, refs[ids[k]], poses[mine], mine, draws, seed,
                                  str(job.decompositions_folder())))
    finally:
        simulate.close()
    return rows, np.concatenate(found)


def _refs_by_content_id(job: JobSpec) -> dict[str, ObjectRef]:
    """{content id: reference} of every object of ``job.objects`` that loads (each loaded once)."""
    found = {}
    for ref in resolve_source(job.objects):
        try:
            found[load_object(ref, job).content_id] = ref
        except MeshRejected:
            continue
    return found
