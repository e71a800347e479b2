"""Two objects on the table (docs/picks.md): the pick benchmark's views with a second object beside the first, as
a robot's table holds them. The first object is dropped at the table centre and settled; the second, in a seeded
orientation, along a seeded direction a seeded gap beyond it (GAPS), and both settle (sim.pick.settle_beside).
One seeded camera sees both; each chooser plans on the whole cloud, and a grasp picks when it lifts and holds
whichever object it closes on (the one with the most of its true surface between the fingers) through the pick
protocol, the other standing beside it (sim.beside) in every trial.

A pair's results are an ObjectPicks named "first+second", so the benchmark's summary and intervals (over pairs)
read them as they read one object's (`onepiece pick --pairs`, PickSpec.pairs). Every chooser but those on the
full mesh (one object's) runs on a pair; the oracle executes every candidate of the view."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.objects import closed_on
from onepiece_dist.core.frames import transform_points
from onepiece_dist.core.mesh import enclosed_volume, sample_surface
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects import ObjectRef, load_object
from onepiece_dist.picks.object_picks import ObjectPicks, ViewPicks, picked_view, process_scorer
from onepiece_dist.picks.shape_check import CHECK_STREAM
from onepiece_dist.picks.views import POOLS, PickView
from onepiece_dist.plan.observation import MIN_POINTS, Observation
from onepiece_dist.plan.planner import propose
from onepiece_dist.plan.scorer import CropRecord
from onepiece_dist.sim.collision import convex_pieces
from onepiece_dist.specs.plan import PickSpec

GAPS = (0.01, 0.05)  # m: the second object dropped this far (uniform) beyond the first along its direction
SURFACE_POINTS = 2000  # true surface samples a grasp is matched to its object by
PAIR_STREAM = 300  # a pair's view streams (300 + view), apart from one object's (100 + view)


@dataclass(frozen=True)
class SceneObject:
    """One object of a scene as the pick world loads it: its mesh, convex pieces, enclosed volume (m^3), density
    (kg/m^3) and friction, and ``surface`` (n, 3) samples of its true surface (mesh frame)."""

    name: str
    mesh: object
    pieces: tuple[np.ndarray, ...]
    volume: float
    density: float
    friction: float
    surface: np.ndarray

    def load_into(self, world) -> None:
        world.load_object(list(self.pieces), self.volume, self.density, self.friction)

    def neighbour(self, resting: np.ndarray):
        """This object standing at ``resting`` (4, 4) beside another (sim.beside.Neighbour)."""
        from onepiece_dist.sim.beside import Neighbour
        from onepiece_dist.sim.world import object_mass

        return Neighbour(self.pieces, object_mass(self.density, self.volume), self.friction, resting)


def scene_object(spec: PickSpec, record: CropRecord, ref: ObjectRef) -> SceneObject:
    """``ref`` loaded as ``spec`` asks for ``record``'s gripper and voxel grid; a bad object raises MeshRejected."""
    loaded = load_object(ref, spec.object_job(record.gripper, record.voxel))
    mesh, volume = loaded.mesh, enclosed_volume(loaded.mesh)
    pieces = convex_pieces(mesh, Path(spec.output) / "collision", spec.sim.collision)
    surface, _ = sample_surface(mesh, SURFACE_POINTS, np.random.default_rng(int(mesh.content_id[:16], 16)))
    return SceneObject(mesh.name, mesh, tuple(pieces), volume, loaded.density(spec.sim.density, volume),
                       loaded.friction, surface)


def pair_seed(spec: PickSpec, pair: tuple[SceneObject, SceneObject], view: int) -> list[int]:
    """The seed every generator of one view of ``pair`` starts from: both objects' content, the seed, the view."""
    return [int(o.mesh.content_id[:16], 16) for o in pair] + [spec.seed, view]


@dataclass(frozen=True)
class PairScene:
    """Both objects at rest (``resting``: their mesh-frame world poses, in pair order) and the view of them."""

    resting: tuple[np.ndarray, np.ndarray]
    view: PickView


def observe_pair(spec: PickSpec, record: CropRecord, world, pair: tuple[SceneObject, SceneObject],
                 view: int) -> PairScene:
    """View ``view`` of ``pair``: settled side by side, seen by one seeded camera aimed between them, and the
    planner's candidates on the cloud of both."""
    from onepiece_dist.sim.pick import observe_scene, pick_camera

    first, second = pair
    rng = np.random.default_rng([*pair_seed(spec, pair, view)[:-1], PAIR_STREAM + view])
    first.load_into(world)
    resting_first = world.settle(rng, first.mesh.vertices)
    gap = float(rng.uniform(*GAPS))
    second.load_into(world)
    world.set_neighbours((first.neighbour(resting_first),))
    resting_second = world.settle_beside(rng, second.mesh.vertices, gap)
    resting = (world.beside.poses(world.client)[0], resting_second)
    vertices = [transform_points(o.mesh.vertices, pose) for o, pose in zip(pair, resting, strict=True)]
    faces = np.vstack([first.mesh.faces, second.mesh.faces + len(first.mesh.vertices)])
    centre = (np.mean(vertices[0], axis=0) + np.mean(vertices[1], axis=0)) / 2
    cam = spec.camera
    drawn = pick_camera(centre, rng, cam.distance, cam.elevation_deg, cam.image_size, cam.fov_deg)
    cloud = observe_scene(np.vstack(vertices), faces, centre, drawn.camera, rng, cam.depth_noise)
    eye = drawn.camera.pose[:3, 3]
    name = f"{first.name}+{second.name} view {view}"
    proposals = propose(Observation(cloud, eye, name), record, spec.plan, rng) if len(cloud) >= MIN_POINTS else None
    seen = PickView(view, resting[0], eye, drawn.distance, drawn.elevation_deg, cloud, proposals, rng,
                    (*pair_seed(spec, pair, view), CHECK_STREAM))
    return PairScene(resting, seen)


class PairExecutions:
    """Candidates of one pair view executed by the pick protocol, each once with a generator of its own (as
    picks.views.Executions): on the object the grasp closes on, the other standing beside it."""

    def __init__(self, spec: PickSpec, world, pair: tuple[SceneObject, SceneObject], scene: PairScene, view: int):
        from onepiece_dist.sim.trials import LabelNoise

        self.world, self.pair, self.scene, self.noise = world, pair, scene, LabelNoise.from_spec(spec.sim)
        self.seed = pair_seed(spec, pair, view)
        self.surfaces = [transform_points(o.surface, pose) for o, pose in zip(pair, scene.resting, strict=True)]
        self.done: dict[tuple[str, int], object] = {}

    def target(self, pose: np.ndarray) -> int:
        """Which object of the pair ``pose`` closes on (core.cloud.objects.closed_on, on their true surfaces)."""
        g = self.world.spec
        return closed_on(self.surfaces, pose, g.closing_depth, g.closing_width, g.closing_height)

    def run(self, pool: str, index: int, pose: np.ndarray):
        from onepiece_dist.sim.pick import execute_pick

        key = (pool, int(index))
        if key not in self.done:
            aimed = self.target(pose)
            self.pair[aimed].load_into(self.world)
            other = 1 - aimed
            self.world.set_neighbours((self.pair[other].neighbour(self.scene.resting[other]),))
            rng = np.random.default_rng([*self.seed, POOLS[pool], int(index)])
            self.done[key] = execute_pick(self.world, pose, self.scene.resting[aimed], self.noise, rng)
        return self.done[key]


def pick_pair(spec: PickSpec, refs: ObjectPair, index: int) -> ObjectPicks:
    """Every view of one pair (named "first+second"); a bad object becomes a rejected result, never an
    exception."""
    from onepiece_dist.sim.pick import pick_world

    start, name = time.perf_counter(), refs.name
    scorer = process_scorer(spec)
    try:
        pair = tuple(scene_object(spec, scorer.record, ref) for ref in (refs.first, refs.second))
    except MeshRejected as err:
        return ObjectPicks(index, name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    world = pick_world(scorer.record.gripper)
    views = tuple(_pair_view(spec, scorer, world, pair, view) for view in range(spec.views))
    return ObjectPicks(index, name, "ok", views, seconds=time.perf_counter() - start)


def _pair_view(spec: PickSpec, scorer, world, pair, view: int) -> ViewPicks:
    scene = observe_pair(spec, scorer.record, world, pair, view)
    seen = scene.view
    if seen.proposals is None:
        empty = {m: () for m in spec.methods}
        return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), 0, empty, empty)
    executions = PairExecutions(spec, world, pair, scene, view)
    return picked_view(spec, scorer, seen, executions, None, f"{pair[0].name}+{pair[1].name}")


@dataclass(frozen=True)
class ObjectPair:
    """Two objects of a source set on the table together: ``first`` settled at the centre, ``second`` beside it."""

    first: ObjectRef
    second: ObjectRef

    @property
    def name(self) -> str:
        return f"{self.first.name}+{self.second.name}"


def pairs_of(refs: list[ObjectRef]) -> list[ObjectPair]:
    """Each object with the next (the last with the first): every object stands in two pairs, once first."""
    return [ObjectPair(refs[k], refs[(k + 1) % len(refs)]) for k in range(len(refs))] if len(refs) > 1 else []
