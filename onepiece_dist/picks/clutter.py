"""Several objects on the table (docs/picks.md): the pick benchmark's views with ``PickSpec.clutter`` objects
together, as a robot's table holds them. The first object is dropped at the table centre and settled; each next
one, in a seeded orientation, along a seeded direction a seeded gap (GAPS) beyond every object already there,
and all settle again (sim.pick.settle_beside). One seeded camera sees them all; each chooser plans on the whole
cloud, and a grasp picks when it lifts and holds whichever object it closes on (the one with the most of its
true surface between the fingers) through the pick protocol, the others standing beside it (sim.beside) in every
trial.

A scene's results are an ObjectPicks named "first+second+...", so the benchmark's summary and intervals (over
scenes) read them as they read one object's (`onepiece pick --clutter N`). Every chooser but those on the full
mesh (one object's) runs on a scene; the oracle executes every candidate of the view."""

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
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.specs.plan import PickSpec

GAPS = (0.01, 0.05)  # m: each next object dropped this far (uniform) beyond those there along its direction
PILE_SPREAD = 0.03  # m: in a pile, each next object's middle dropped within this of theirs (along x and y)
SURFACE_POINTS = 2000  # true surface samples a grasp is matched to its object by
SCENE_STREAM = 300  # a scene's view streams (300 + view), apart from one object's (100 + view)
WORKSPACE = 0.25  # m: the cloud kept around the scene's centre (several objects spread wider than one)


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
    return loaded_object(ref, spec.object_job(record.gripper, record.voxel), Path(spec.output) / "collision")


def loaded_object(ref: ObjectRef, job: JobSpec, collision: Path) -> SceneObject:
    """``ref`` loaded as ``job`` asks (its physics: ``job.sim``), its convex pieces cached under ``collision``; a
    bad object raises MeshRejected."""
    loaded = load_object(ref, job)
    mesh, volume = loaded.mesh, enclosed_volume(loaded.mesh)
    pieces = convex_pieces(mesh, collision, job.sim.collision)
    surface, _ = sample_surface(mesh, SURFACE_POINTS, np.random.default_rng(int(mesh.content_id[:16], 16)))
    return SceneObject(mesh.name, mesh, tuple(pieces), volume, loaded.density(job.sim.density, volume),
                       loaded.friction, surface)


def scene_seed(spec: PickSpec, objects: tuple[SceneObject, ...], view: int) -> list[int]:
    """The seed every generator of one view of ``objects`` starts from: their content, the seed, the view."""
    return [int(o.mesh.content_id[:16], 16) for o in objects] + [spec.seed, view]


@dataclass(frozen=True)
class Scene:
    """The objects at rest (``resting``: their mesh-frame world poses, in the scene's order) and the view of them."""

    resting: tuple[np.ndarray, ...]
    view: PickView


def settle_scene(world, objects: tuple[SceneObject, ...], rng: np.random.Generator, pile: bool = False
                 ) -> tuple[np.ndarray, ...]:
    """``objects`` dropped one by one, each next beside those already there (or, in a ``pile``, onto them), all
    settled: their resting poses."""
    first = objects[0]
    first.load_into(world)
    resting = [world.settle(rng, first.mesh.vertices)]
    for nxt in objects[1:]:
        gap = None if pile else float(rng.uniform(*GAPS))
        nxt.load_into(world)
        world.set_neighbours(tuple(o.neighbour(pose) for o, pose in zip(objects[:len(resting)], resting,
                                                                          strict=True)))
        placed = (world.settle_onto(rng, nxt.mesh.vertices, PILE_SPREAD, WORKSPACE) if pile else
                  world.settle_beside(rng, nxt.mesh.vertices, gap, WORKSPACE))
        resting = [*world.beside.poses(world.client), placed]
    return tuple(resting)


def observe_scene_view(spec: PickSpec, record: CropRecord, world, objects: tuple[SceneObject, ...],
                       view: int) -> Scene:
    """View ``view`` of ``objects``: settled side by side, seen by one seeded camera aimed at their middle, and
    the planner's candidates on the cloud of them all."""
    resting, rng = settled(spec, world, objects, view)
    return Scene(resting, seen_scene(spec, record, objects, resting, rng, view))


def settled(spec: PickSpec, world, objects: tuple[SceneObject, ...], view: int
            ) -> tuple[tuple[np.ndarray, ...], np.random.Generator]:
    """``objects`` settled for view ``view`` (settle_scene, from the view's own stream), and that stream."""
    rng = np.random.default_rng([*scene_seed(spec, objects, view)[:-1], SCENE_STREAM + view])
    return settle_scene(world, objects, rng, spec.pile), rng


def seen_scene(spec: PickSpec, record: CropRecord, objects: tuple[SceneObject, ...],
               resting: tuple[np.ndarray, ...], rng: np.random.Generator, view: int) -> PickView:
    """``objects`` resting at ``resting`` seen by a camera drawn from ``rng``, aimed at their middle, and the
    planner's candidates on the cloud (the view's checks seeded by the objects, the spec's seed and ``view``)."""
    from onepiece_dist.sim.pick import observe_scene, pick_camera

    vertices, faces = scene_triangles(objects, resting)
    centre = np.mean([np.mean(v, axis=0) for v in vertices], axis=0)
    cam = spec.camera
    drawn = pick_camera(centre, rng, cam.distance, cam.elevation_deg, cam.image_size, cam.fov_deg)
    cloud = observe_scene(np.vstack(vertices), faces, centre, drawn.camera, rng, cam.depth_noise, WORKSPACE,
                          cam.flying_pixels, spec.plan.drop_flying)
    eye = drawn.camera.pose[:3, 3]
    name = f"{scene_name(objects)} view {view}"
    proposals = propose(Observation(cloud, eye, name), record, spec.plan, rng) if len(cloud) >= MIN_POINTS else None
    return PickView(view, resting[0], eye, drawn.distance, drawn.elevation_deg, cloud, proposals, rng,
                    (*scene_seed(spec, objects, view), CHECK_STREAM))


def scene_triangles(objects: tuple[SceneObject, ...], resting: tuple[np.ndarray, ...]
                    ) -> tuple[list[np.ndarray], np.ndarray]:
    """Each object's mesh vertices where it rests (world frame), and the faces of them all as one mesh (indices
    into the vertices stacked in order)."""
    vertices = [transform_points(o.mesh.vertices, pose) for o, pose in zip(objects, resting, strict=True)]
    offsets = np.cumsum([0] + [len(o.mesh.vertices) for o in objects[:-1]])
    return vertices, np.vstack([o.mesh.faces + k for o, k in zip(objects, offsets, strict=True)])


def scene_name(objects) -> str:
    return "+".join(o.name for o in objects)


class SceneExecutions:
    """Candidates of one scene's view executed by the pick protocol, each once with a generator of its own (as
    picks.views.Executions): on the object the grasp closes on, the others standing beside it."""

    def __init__(self, spec: PickSpec, world, objects: tuple[SceneObject, ...], scene: Scene, view: int):
        from onepiece_dist.sim.trials import LabelNoise

        self.world, self.objects, self.scene, self.noise = world, objects, scene, LabelNoise.from_spec(spec.sim)
        self.seed = scene_seed(spec, objects, view)
        self.surfaces = [transform_points(o.surface, pose) for o, pose in zip(objects, scene.resting, strict=True)]
        self.done: dict[tuple[str, int], object] = {}

    def target(self, pose: np.ndarray) -> int:
        """Which object ``pose`` closes on (core.cloud.objects.closed_on, on their true surfaces)."""
        g = self.world.spec
        return closed_on(self.surfaces, pose, g.closing_depth, g.closing_width, g.closing_height)

    def run(self, pool: str, index: int, pose: np.ndarray):
        from onepiece_dist.sim.pick import execute_pick

        key = (pool, int(index))
        if key not in self.done:
            aimed = self._staged(pose)
            rng = np.random.default_rng([*self.seed, POOLS[pool], int(index)])
            self.done[key] = execute_pick(self.world, pose, self.scene.resting[aimed], self.noise, rng)
        return self.done[key]

    def aftermath(self, pose: np.ndarray) -> list[np.ndarray]:
        """Where each of the scene's objects rests (4, 4, in order) after the hand executed ``pose`` once (the
        protocol's nominal trial, which draws nothing), let go and parked: what a failed pick pushed or dropped
        stays where it came to rest. A start in collision moves nothing (the hand never went in)."""
        from onepiece_dist.sim.pick import execute_trial

        aimed = self._staged(pose)
        failure = execute_trial(self.world, pose, self.scene.resting[aimed], self.noise, np.random.default_rng(0),
                                perturbed=False)
        if failure == "start_collision":
            return list(self.scene.resting)
        placed, others = self.world.let_go(), iter(self.world.beside.poses(self.world.client))
        return [placed if k == aimed else next(others) for k in range(len(self.objects))]

    def _staged(self, pose: np.ndarray) -> int:
        """The object ``pose`` closes on loaded into the world, the others beside it at rest: its index."""
        aimed = self.target(pose)
        self.objects[aimed].load_into(self.world)
        self.world.set_neighbours(tuple(o.neighbour(rest) for k, (o, rest) in
                                        enumerate(zip(self.objects, self.scene.resting, strict=True)) if k != aimed))
        return aimed


def pick_scene(spec: PickSpec, group: ObjectGroup, index: int) -> ObjectPicks:
    """Every view of one scene (named "first+second+..."); a bad object becomes a rejected result, never an
    exception."""
    start = time.perf_counter()
    try:
        scorer, world, objects = loaded_scene(spec, group)
    except MeshRejected as err:
        return ObjectPicks(index, group.name, "rejected", reason=err.reason, seconds=time.perf_counter() - start)
    views = tuple(_scene_view(spec, scorer, world, objects, view) for view in spec.view_indices)
    return ObjectPicks(index, group.name, "ok", views, seconds=time.perf_counter() - start)


def loaded_scene(spec: PickSpec, group: ObjectGroup) -> tuple:
    """This process's scorer and pick world, and ``group``'s objects loaded; MeshRejected for a bad object."""
    from onepiece_dist.sim.pick import pick_world

    scorer = process_scorer(spec)
    objects = tuple(scene_object(spec, scorer.record, ref) for ref in group.refs)
    return scorer, pick_world(scorer.record.gripper), objects


def _scene_view(spec: PickSpec, scorer, world, objects, view: int) -> ViewPicks:
    scene = observe_scene_view(spec, scorer.record, world, objects, view)
    seen = scene.view
    if seen.proposals is None:
        empty = {m: () for m in spec.methods}
        return ViewPicks(view, seen.distance, seen.elevation_deg, len(seen.cloud), 0, empty, empty)
    executions = SceneExecutions(spec, world, objects, scene, view)
    return picked_view(spec, scorer, seen, executions, None, scene_name(objects))


@dataclass(frozen=True)
class ObjectGroup:
    """Objects of a source set on the table together: the first settled at the centre, the others beside it."""

    refs: tuple[ObjectRef, ...]

    @property
    def name(self) -> str:
        return scene_name(self.refs)


def groups_of(refs: list[ObjectRef], size: int) -> list[ObjectGroup]:
    """Each object with the next ``size - 1`` (wrapping round): every object stands in ``size`` scenes, once
    first; none where the source holds fewer than ``size`` objects."""
    if len(refs) < size:
        return []
    return [ObjectGroup(tuple(refs[(k + j) % len(refs)] for j in range(size))) for k in range(len(refs))]
