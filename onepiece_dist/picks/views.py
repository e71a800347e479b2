"""One view of the pick benchmark, written once for every flow that picks (the benchmark's choosers, many
networks' picks, the pick-labelled training set): the object dropped on the table and settled, a seeded camera,
its cloud, the planner's candidates; and the executions of candidates, each by the pick protocol with a generator
of its own, so a candidate's outcome depends on neither who chose it nor its draws' order (what the world
executed before it still moves a rare outcome: sim.pick.execute_pick)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.sampling import object_rng
from onepiece_dist.objects import load_object
from onepiece_dist.picks.shape_check import CHECK_STREAM
from onepiece_dist.plan.observation import MIN_POINTS, Observation
from onepiece_dist.plan.planner import Proposals, propose, rank
from onepiece_dist.plan.scorer import CropRecord
from onepiece_dist.sim.collision import load_simulated
from onepiece_dist.specs.plan import PickSpec

# the pools a candidate is drawn from, each with a stream of generators of its own
POOLS = {"view": 0, "mesh": 1, "top_down": 2}
AGAIN = 5858  # the stream of a candidate's fresh executions (Executions.again)


def view_seed(spec: PickSpec, mesh, view: int) -> tuple[int, int, int]:
    """The seed every generator of one view of ``mesh`` starts from: the object's content, the spec's seed, the view."""
    return int(mesh.content_id[:16], 16), spec.seed, view


@dataclass(frozen=True)
class PickView:
    """A settled object seen once: ``resting`` (4, 4) its mesh-frame world pose, the camera's position, distance
    (m) and elevation (degrees), the observed ``cloud`` (m, 3) and the planner's ``proposals`` (None when the
    camera saw fewer than MIN_POINTS points); ``rng`` continues the view's seeded stream; ``check_seed`` seeds
    the checks of its grasps on the shape it implies (picks.shape_check), apart from every other stream."""

    view: int
    resting: np.ndarray
    eye: np.ndarray
    distance: float
    elevation_deg: float
    cloud: np.ndarray
    proposals: Proposals | None
    rng: np.random.Generator
    check_seed: tuple[int, ...] = ()


def simulated_object(spec: PickSpec, record: CropRecord, ref):
    """``ref`` loaded as ``spec`` asks for ``record``'s gripper and voxel grid, and a pick world holding it as a
    simulated body: (world, loaded object). A bad object raises MeshRejected (each flow makes it a result)."""
    from onepiece_dist.sim.pick import pick_world

    loaded = load_object(ref, spec.object_job(record.gripper, record.voxel))
    world = pick_world(record.gripper)
    load_simulated(world, loaded, Path(spec.output) / "collision", spec.sim.collision, spec.sim.density)
    return world, loaded


def observe_view(spec: PickSpec, record: CropRecord, world, mesh, view: int) -> PickView:
    """View ``view`` of ``mesh`` (loaded in ``world``): settled, seen, and its candidates proposed."""
    from onepiece_dist.sim.pick import observe, pick_camera

    rng = object_rng(mesh.content_id, spec.seed, stream=100 + view)
    resting = world.settle(rng, mesh.vertices)
    cam = spec.camera
    drawn = pick_camera(resting[:3, 3], rng, cam.distance, cam.elevation_deg, cam.image_size, cam.fov_deg)
    cloud = observe(mesh.vertices, mesh.faces, resting, drawn.camera, rng, cam.depth_noise, cam.flying_pixels,
                    spec.plan.drop_flying)
    eye = drawn.camera.pose[:3, 3]
    proposals = None
    if len(cloud) >= MIN_POINTS:
        proposals = propose(Observation(cloud, eye, f"{mesh.name} view {view}"), record, spec.plan, rng)
    return PickView(view, resting, eye, drawn.distance, drawn.elevation_deg, cloud, proposals, rng,
                    (*view_seed(spec, mesh, view), CHECK_STREAM))


class Executions:
    """Candidates of one view executed by the pick protocol, each once: ``run(pool, index, pose)`` executes
    candidate ``index`` of ``pool`` (POOLS) with its own generator ([object, seed, view, pool, index]) and keeps
    the outcome, so every chooser that picks it meets the same outcome."""

    def __init__(self, spec: PickSpec, world, mesh, resting: np.ndarray, view: int):
        from onepiece_dist.sim.trials import LabelNoise

        self.world, self.resting, self.noise = world, resting, LabelNoise.from_spec(spec.sim)
        self.seed = list(view_seed(spec, mesh, view))
        self.done: dict[tuple[str, int], object] = {}

    def run(self, pool: str, index: int, pose: np.ndarray):
        from onepiece_dist.sim.pick import execute_pick

        key = (pool, int(index))
        if key not in self.done:
            rng = np.random.default_rng([*self.seed, POOLS[pool], int(index)])
            self.done[key] = execute_pick(self.world, pose, self.resting, self.noise, rng)
        return self.done[key]

    def again(self, pool: str, index: int, pose: np.ndarray, draw: int):
        """Candidate ``index`` of ``pool`` executed once more, its ``draw``-th fresh execution (draw >= 1; draw 0
        is ``run``'s), with a generator of its own ([object, seed, view, pool, index, AGAIN, draw]); not kept."""
        from onepiece_dist.sim.pick import execute_pick

        rng = np.random.default_rng([*self.seed, POOLS[pool], int(index), AGAIN, int(draw)])
        return execute_pick(self.world, pose, self.resting, self.noise, rng)

    def drawn(self, pool: str, index: int, pose: np.ndarray, count: int, first: int = 0) -> tuple:
        """Candidate ``index`` of ``pool`` executed at each of its draws ``first`` .. ``first + count - 1`` (draw 0
        is ``run``'s, kept; the others ``again``'s), in draw order: their outcomes (sim.pick.PickOutcome)."""
        return tuple(self.run(pool, index, pose) if draw == 0 else self.again(pool, index, pose, draw)
                     for draw in range(first, first + count))

    def picked(self, pool: str, index: int, pose: np.ndarray, count: int, first: int = 0) -> tuple[bool, ...]:
        """Whether candidate ``index`` of ``pool`` picked at each of those draws (``drawn``)."""
        return tuple(bool(outcome.success) for outcome in self.drawn(pool, index, pose, count, first))


def ranked_indices(proposals: Proposals, scores: np.ndarray, record: CropRecord, plan, keep: int) -> tuple:
    """The planner's ``keep`` best of ``proposals`` by ``scores`` (planner.rank) and each one's index among them."""
    ranked = rank(proposals, scores, record, plan, keep=keep)
    return ranked, [index_of(proposals.poses, g.pose) for g in ranked]


def index_of(poses: np.ndarray, pose: np.ndarray) -> int:
    """Which of ``poses`` (n, 4, 4) a ranked grasp's ``pose`` is (rank returns the pose itself)."""
    return int(np.argmin(np.abs(poses - pose).reshape(len(poses), -1).max(axis=1)))
