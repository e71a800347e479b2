"""Picks from a table in pybullet (docs/picks.md): the object dropped on a table and settled, seen by one depth
camera, a chosen grasp executed as a robot would: open at a pregrasp 5 cm back along the approach, approach, close,
then the label protocol's lift and shake (sim.trials), the table there throughout and gravity on.

The table is a static box whose top is the plane z = 0; the object's frame is its mesh frame; grasp poses are
gripper-to-world.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from onepiece_dist.core import portable
from onepiece_dist.core.cloud.flying import without_flying
from onepiece_dist.core.frames import compose_poses, perturb_pose, quat_from_matrix, transform_points
from onepiece_dist.sim.beside import Beside, Neighbour
from onepiece_dist.sim.trials import (
    LabelNoise,
    close_fingers,
    finger_contacts,
    lift_and_shake,
    lift_steps,
    move_gripper,
)
from onepiece_dist.sim.views import (
    Camera,
    back_project,
    buffer_of,
    camera_at,
    depth_images,
    linear_depth,
    mixed_edges,
)
from onepiece_dist.sim.world import SimWorld, matrix_from_pose
from onepiece_dist.specs.job import GripperSpec

TABLE_HALF = 0.5  # m: the table's half width
TABLE_THICKNESS = 0.02
PARK_HEIGHT = 1.0  # m: where the gripper waits above the table while the object settles
DROP_CLEARANCE = 0.005  # m between the table and the object's lowest point when it is dropped
SETTLE_SECONDS, SETTLE_CHECK, SETTLE_SPEED = 3.0, 24, 0.01  # at most; steps between checks; m/s and rad/s at rest
PREGRASP = 0.05  # m back along the approach (VGN's)
APPROACH_STEP = 0.002  # m per approach step (VGN's)
WORKSPACE = 0.15  # m: the cloud kept around the object's resting place (VGN's workspace is a 0.3 m cube)
START_TOLERANCE = 1e-3  # m of penetration at the pregrasp that counts as a collision
ROLLING_FRICTION = 0.002  # a table's resistance to rolling: a can on its side stops instead of leaving the table
DROPS = 5  # drops tried until the object comes to rest within WORKSPACE of the table centre
# the table as a box for the depth renderer: (half extents, centre), read only
TABLE_BOX = (np.array([TABLE_HALF, TABLE_HALF, TABLE_THICKNESS / 2]), np.array([0.0, 0.0, -TABLE_THICKNESS / 2]))


class PickWorld(SimWorld):
    """A :class:`SimWorld` with a table; the gripper waits above it while the object settles. Other objects may
    stand beside the object (``beside``, sim.beside: set after each ``load_object``, which removes them)."""

    def _connect(self) -> None:
        super()._connect()
        self.beside = Beside()
        c = self.client
        table = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[TABLE_HALF, TABLE_HALF, TABLE_THICKNESS / 2],
                                        physicsClientId=c)
        self.table = pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=table,
                                        basePosition=[0, 0, -TABLE_THICKNESS / 2], physicsClientId=c)
        pb.changeDynamics(self.table, -1, lateralFriction=1.0, rollingFriction=ROLLING_FRICTION,
                          spinningFriction=ROLLING_FRICTION, physicsClientId=c)
        self.park()

    def _unload(self) -> None:
        self.beside.clear(self.client)
        super()._unload()

    def set_neighbours(self, neighbours: tuple[Neighbour, ...]) -> None:
        """Stand ``neighbours`` beside the loaded object, at their resting poses."""
        self.beside.set(self.client, neighbours)

    def as_neighbour(self, resting: np.ndarray) -> Neighbour:
        """The loaded object (its own mass and friction) as a neighbour resting at ``resting`` (4, 4)."""
        return Neighbour(tuple(p + self._centroid for p in self._pieces), self._mass, self.object_friction,
                         np.array(resting, dtype=np.float64))

    def park(self) -> None:
        pose = np.eye(4)
        pose[2, 3] = PARK_HEIGHT
        move_gripper(self, pose, reset=True)

    def set_object_pose(self, pose: np.ndarray) -> None:
        """Put the object's mesh frame at ``pose`` (4, 4) in the world, at rest."""
        com_world = transform_points(self.com[None], pose)[0]
        pb.resetBasePositionAndOrientation(self.obj, com_world.tolist(), quat_from_matrix(pose[:3, :3]),
                                           physicsClientId=self.client)
        pb.resetBaseVelocity(self.obj, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)

    def settle(self, rng: np.random.Generator, vertices: np.ndarray) -> np.ndarray:
        """Drop the object in a seeded random orientation just above the table centre and let it come to rest
        (gravity on, the gripper parked); dropped again (up to DROPS times) while it rolls out of the workspace.
        ``vertices`` (V, 3) the mesh's. Returns its mesh-frame world pose.

        The object's body is made again first: Bullet keeps contact caches (and the solver's warm start) on a
        body, so a body that took earlier picks would settle a little differently from a new one, and a view
        would depend on what the world executed before it."""
        self.carry_payload(None)
        for _ in range(DROPS):
            resting = self._drop(rng, vertices)
            if on_table(resting, WORKSPACE / 2):
                break
        return resting

    def settle_beside(self, rng: np.random.Generator, vertices: np.ndarray, gap: float,
                      within: float = WORKSPACE) -> np.ndarray:
        """Drop the object in a seeded random orientation beside its neighbours (standing at their resting poses):
        along a seeded horizontal direction from the table centre, ``gap`` (m) beyond their farthest point that
        way, and let it and them come to rest; dropped again (up to DROPS times, the neighbours back at rest)
        while any of them rests off the table or further than ``within`` (m, along x or y) from its centre.
        Returns its mesh-frame world pose (the neighbours': ``beside.poses``)."""
        return self._settle_among(rng, vertices, within, gap=gap)

    def settle_onto(self, rng: np.random.Generator, vertices: np.ndarray, spread: float,
                    within: float = WORKSPACE) -> np.ndarray:
        """Drop the object in a seeded random orientation onto its neighbours (a pile: they stand at their resting
        poses): its lowest point DROP_CLEARANCE above their highest, its centre at a seeded place within
        ``spread`` (m, along x and y) of their middle, and let it and them come to rest; dropped again (up to
        DROPS times, the neighbours back at rest) while any of them rests off the table or further than
        ``within`` (m, along x or y) from its centre. Returns its mesh-frame world pose (the neighbours':
        ``beside.poses``)."""
        return self._settle_among(rng, vertices, within, onto=spread)

    def _settle_among(self, rng: np.random.Generator, vertices: np.ndarray, within: float,
                      gap: float | None = None, onto: float | None = None) -> np.ndarray:
        """The object dropped among its neighbours (``_drop``'s ``gap`` or ``onto``) until it and they all rest on
        the table within ``within`` of its centre (DROPS tries, the neighbours back at rest each): its pose."""
        for _ in range(DROPS):
            self.carry_payload(None)
            self.beside.reset(self.client)
            resting = self._drop(rng, vertices, gap, onto)
            if all(on_table(p, within) for p in [resting, *self.beside.poses(self.client)]):
                break
        return resting

    def _drop(self, rng: np.random.Generator, vertices: np.ndarray, gap: float | None = None,
              onto: float | None = None) -> np.ndarray:
        self.park()
        pose = np.eye(4)
        pose[:3, :3] = _random_rotation(rng)
        turned = transform_points(vertices, pose)
        pose[2, 3] = DROP_CLEARANCE - float(turned[:, 2].min())
        if gap is not None:
            pose[:2, 3] = self._beside_place(rng, turned[:, :2], gap)
        if onto is not None:
            pose[:3, 3] += self._onto_place(rng, turned, onto)
        self.set_object_pose(pose)
        return self._come_to_rest()

    def settle_in_place(self, resting: np.ndarray) -> np.ndarray:
        """The loaded object put at ``resting`` (4, 4) at rest among its neighbours (at theirs), and let it and
        them come to rest (gravity on, the gripper parked): what leaned on an object taken away falls. Returns
        its mesh-frame world pose (the neighbours': ``beside.poses``)."""
        self.carry_payload(None)
        self.park()
        self.set_object_pose(resting)
        return self._come_to_rest()

    def let_go(self) -> np.ndarray:
        """The hand parked from wherever a trial left it (what it held falls), and the object and its neighbours
        left to come to rest where they are: the object's mesh-frame world pose (the neighbours': ``beside.poses``)."""
        self.park()
        return self._come_to_rest()

    def _come_to_rest(self) -> np.ndarray:
        """Step with gravity until the object and its neighbours are at rest (SETTLE_SECONDS at most): its pose."""
        pb.setGravity(0, 0, -9.81, physicsClientId=self.client)
        for _ in range(int(SETTLE_SECONDS / self.physics.time_step / SETTLE_CHECK)):
            for _ in range(SETTLE_CHECK):
                pb.stepSimulation(physicsClientId=self.client)
            linear, angular = pb.getBaseVelocity(self.obj, physicsClientId=self.client)
            if max(np.abs(linear).max(), np.abs(angular).max(), self.beside.speed(self.client)) < SETTLE_SPEED:
                break
        return self.object_pose()

    def _beside_place(self, rng: np.random.Generator, footprint: np.ndarray, gap: float) -> np.ndarray:
        """(2,) where to put the mesh origin of an object whose turned vertices (about that origin) span
        ``footprint`` (n, 2): along a seeded horizontal direction, ``gap`` beyond the neighbours' farthest point
        that way (portable sines: the same place on every CPU)."""
        sin, cos = portable.sin_cos(np.array([rng.uniform(0, 2 * np.pi)]))
        way = np.array([cos[0], sin[0]])
        far = max((float(np.max(transform_points(np.vstack(n.pieces), n.resting)[:, :2] @ way))
                   for n in self.beside.neighbours), default=0.0)
        return way * (far + gap - float(np.min(footprint @ way)))

    def _onto_place(self, rng: np.random.Generator, turned: np.ndarray, spread: float) -> np.ndarray:
        """(3,) where to move an object whose turned vertices (about its mesh origin, lowest at z = 0) are
        ``turned`` (n, 3) so that it lies above the neighbours: its vertices' middle at a seeded place within
        ``spread`` of theirs (along x and y), its lowest point at their highest."""
        stood = np.vstack([transform_points(np.vstack(n.pieces), n.resting) for n in self.beside.neighbours])
        middle = (stood[:, :2].min(axis=0) + stood[:, :2].max(axis=0)) / 2
        mine = (turned[:, :2].min(axis=0) + turned[:, :2].max(axis=0)) / 2
        place = middle + rng.uniform(-spread, spread, 2) - mine
        return np.array([place[0], place[1], float(stood[:, 2].max())])


def on_table(pose: np.ndarray, within: float = TABLE_HALF) -> bool:
    """Whether an object whose mesh frame rests at ``pose`` (4, 4) is on the table, within ``within`` (m, along x
    and y) of its centre."""
    return bool(np.all(np.abs(pose[:2, 3]) < within) and pose[2, 3] > -TABLE_THICKNESS)


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.sqrt(np.sum(q * q))
    return matrix_from_pose([0, 0, 0], q.tolist())[:3, :3]


@dataclass(frozen=True)
class PickCamera:
    """The view's camera, and the distance (m) and elevation (degrees) it was drawn at."""

    camera: Camera
    distance: float
    elevation_deg: float


def pick_camera(target: np.ndarray, rng: np.random.Generator, distance: tuple[float, float],
                elevation_deg: tuple[float, float], size: int, fov_deg: float) -> PickCamera:
    """A camera looking at ``target`` (3,) from a seeded distance, elevation above the table and azimuth (portable
    sines: the same camera on every CPU)."""
    d, elevation, azimuth = rng.uniform(*distance), rng.uniform(*elevation_deg), rng.uniform(0, 2 * np.pi)
    sin, cos = portable.sin_cos(np.array([elevation * np.pi / 180, azimuth]))
    eye = target + d * np.array([cos[0] * cos[1], cos[0] * sin[1], sin[0]])
    return PickCamera(camera_at(eye, target, size, fov_deg), float(d), float(elevation))


def observe(vertices: np.ndarray, faces: np.ndarray, object_pose: np.ndarray, camera: Camera,
            rng: np.random.Generator, depth_noise: float = 0.0, flying_pixels: float = 0.0,
            drop_flying: float = 0.0) -> np.ndarray:
    """(m, 3) world points the camera sees of the object at ``object_pose`` on the table, kept within WORKSPACE
    of the object's resting place (a workspace crop), with Gaussian ``depth_noise`` (m) along each ray and a
    ``flying_pixels`` share of its edge pixels mixed, those found flying at ``drop_flying`` dropped
    (observe_scene)."""
    return observe_scene(transform_points(vertices, object_pose), faces, object_pose[:3, 3], camera, rng,
                         depth_noise, flying_pixels=flying_pixels, drop_flying=drop_flying)


def observe_scene(vertices: np.ndarray, faces: np.ndarray, centre: np.ndarray, camera: Camera,
                  rng: np.random.Generator, depth_noise: float = 0.0, half: float = WORKSPACE,
                  flying_pixels: float = 0.0, drop_flying: float = 0.0) -> np.ndarray:
    """(m, 3) world points the camera sees of the triangles ``vertices`` (world frame; every object of the scene)
    and ``faces`` on the table, kept within ``half`` (m, along x and y) of ``centre`` (3,), with a
    ``flying_pixels`` share of the pixels at its depth edges mixed across them (sim.views.mixed_edges) and
    Gaussian ``depth_noise`` (m); nothing is drawn for either where it is 0. With ``drop_flying`` (m) the planner
    drops the image's flying pixels at that tolerance before back-projecting (core.cloud.flying; draws nothing)."""
    depth = depth_images(vertices, faces, [camera], TABLE_BOX)[0]
    if flying_pixels > 0:
        depth = buffer_of(mixed_edges(linear_depth(depth, camera), flying_pixels, rng), camera)
    if drop_flying > 0:
        depth = buffer_of(without_flying(linear_depth(depth, camera), drop_flying), camera)
    points = back_project(depth, camera)
    if depth_noise > 0 and len(points):
        rays = points - camera.pose[:3, 3]
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        points = points + rays * rng.normal(0, depth_noise, (len(points), 1))
    near = np.all(np.abs(points[:, :2] - centre[:2]) < half, axis=1) & (points[:, 2] > -0.005)
    return points[near]


# why a pick failed: the gripper met the object or the table at the pregrasp; the fingers closed without both
# touching the object; it slipped out while lifted; it fell out while shaken
FAILURES = ("start_collision", "no_contact", "slipped_lifting", "dropped_shaking")


@dataclass(frozen=True)
class PickOutcome:
    """One executed grasp: ``success`` (every trial held, or the nominal one), ``trials`` held of ``tried``, and
    why the first failing trial failed ('' when none): one of FAILURES."""

    success: bool
    held: int
    tried: int
    failure: str


def execute_pick(world: PickWorld, grasp: np.ndarray, resting: np.ndarray, noise: LabelNoise,
                 rng: np.random.Generator) -> PickOutcome:
    """Execute ``grasp`` (4, 4, gripper-to-world) on the object resting at ``resting`` by the label protocol:
    the nominal trial and ``noise.trials - 1`` perturbed ones (pose and friction noise), each from the object at
    rest; with ``noise.every_trial`` the pick succeeds when every trial held (it stops at the first that fails),
    else when the nominal one held. Each trial starts from a new body of the object (Bullet keeps contact caches
    on a body). Bullet still keeps a little across trials (the gripper's and the table's bodies, body ids that
    grow with each new body), so what the world executed before can move a rare outcome: in the pick study
    (docs/studies/pick_labels), judging 24 networks instead of 16 on the same views changed 1 of 96 outcomes of
    the same random candidates. The same executions in the same order give the same bytes."""
    held, failure = 0, ""
    for trial in range(noise.trials):
        failure = execute_trial(world, grasp, resting, noise, rng, perturbed=trial > 0)
        held += failure == ""
        if failure and (noise.every_trial or trial == 0):
            return PickOutcome(False, held, trial + 1, failure)
    return PickOutcome(True, held, noise.trials, "")


def execute_trial(world: PickWorld, grasp: np.ndarray, resting: np.ndarray, noise: LabelNoise,
                  rng: np.random.Generator, perturbed: bool) -> str:
    """One trial of the pick protocol from the object at rest: '' when it held, else why not. ``perturbed``: at a
    pose and finger friction drawn from ``noise`` and ``rng`` (the protocol's trials after the first), else the
    nominal one (nothing drawn)."""
    base_friction = world.spec.friction
    pose = perturb_pose(grasp, rng, noise.translation, noise.rotation) if perturbed else grasp
    friction = base_friction * max(0.05, 1 + rng.normal(0, noise.friction)) if perturbed else base_friction
    world.set_finger_friction(friction)
    try:
        return _one_pick(world, pose, resting)
    finally:
        world.set_finger_friction(base_friction)


def _one_pick(world: PickWorld, pose: np.ndarray, resting: np.ndarray) -> str:
    """One trial: '' when the object is held after lifting and shaking, else why not."""
    c = world.client
    world.carry_payload(None)
    world.set_object_pose(resting)
    world.beside.reset(c)
    pb.setGravity(0, 0, -9.81, physicsClientId=c)
    back = np.eye(4)
    back[0, 3] = -PREGRASP
    pregrasp = compose_poses(pose, back)
    move_gripper(world, pregrasp, reset=True)
    for link in (0, 1):
        pb.resetJointState(world.gripper, link, 0.0, 0.0, physicsClientId=c)
        pb.setJointMotorControl2(world.gripper, link, pb.VELOCITY_CONTROL, targetVelocity=0, force=0,
                                 physicsClientId=c)
    pb.performCollisionDetection(physicsClientId=c)
    if any(p[8] < -START_TOLERANCE for body in (world.obj, world.table, *world.beside.bodies)
           for p in pb.getContactPoints(world.gripper, body, physicsClientId=c)):
        return "start_collision"
    steps = int(round(PREGRASP / APPROACH_STEP))
    for k in range(1, steps + 1):
        step = pregrasp.copy()
        step[:3, 3] = pregrasp[:3, 3] + (pose[:3, 3] - pregrasp[:3, 3]) * k / steps
        move_gripper(world, step)
        pb.stepSimulation(physicsClientId=c)
    close_fingers(world)
    if not all(finger_contacts(world)):
        return "no_contact"
    lost_at: list[int] = []
    held, _ = lift_and_shake(world, world.gripper_pose(), lost_at)
    if held:
        return ""
    return "slipped_lifting" if lost_at and lost_at[0] < lift_steps(world.physics.time_step) else "dropped_shaking"


_WORLDS: dict[GripperSpec, PickWorld] = {}


def pick_world(gripper: GripperSpec) -> PickWorld:
    """This process's one pick world for ``gripper`` (created on first use, then reused)."""
    if gripper not in _WORLDS:
        _WORLDS[gripper] = PickWorld(gripper)
    return _WORLDS[gripper]
