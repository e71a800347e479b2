"""One pybullet DIRECT client per process, reused across objects: a floating parallel-jaw gripper built from
:class:`GripperSpec` and one object at a time.

The gripper base frame is the gripper frame (origin at the palm centre, on the palm face; its inertial frame
coincides). The base is a box (the palm) held by a fixed constraint that trials move; two prismatic fingers, coupled
by a gear so they keep the same opening (as the Panda hand's mimic joint), close along v with a force limit. The
object is one rigid body; its frame is its mesh frame; it starts at the world origin, so candidate poses (gripper
in the object frame) are also world poses at the start of a trial. The Franka hand (the panda preset) adds the hull
of its own collision mesh (pybullet_data franka_panda/meshes/collision/hand.obj) to the palm, where the planner's
collision test adds its bounds (core.sampling.franka_hand_box).
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from onepiece_dist.core.frames import apply_rotation, quat_from_matrix
from onepiece_dist.core.sampling import FRANKA_FINGERTIP_Z, FRANKA_HAND
from onepiece_dist.specs.job import GripperSpec

TIME_STEP = 1.0 / 240.0
SOLVER_ITERATIONS = 50
REFERENCE_FORCE = 40.0  # N: the default gripper's closing force, at which SOLVER_ITERATIONS converge
CONE_FRICTION = False  # pyramid friction (two directions, each limited by mu N), as MuJoCo's default cone
FINGER_COUPLING_FORCE = 1000.0  # N: the gear that keeps both fingers at the same opening
MIN_MASS, MAX_MASS = 0.05, 2.0  # kg
PAYLOAD_RADIUS = 0.02  # m: a payload's inertia is a solid sphere's of this radius
PAYLOAD_REBUILDS_PER_CLIENT = 20_000  # about 100 MB that pybullet frees only with its client


@dataclass(frozen=True)
class BodyIds:
    gripper: int
    constraint: int
    obj: int
    com: np.ndarray  # (3,) object centre of mass in its mesh frame


def matrix_from_pose(position, quaternion) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = np.reshape(pb.getMatrixFromQuaternion(quaternion), (3, 3))
    pose[:3, 3] = position
    return pose


@dataclass(frozen=True)
class PhysicsSettings:
    """Integrator settings of a :class:`SimWorld` (docs/trials.md says why these values)."""

    time_step: float = TIME_STEP
    solver_iterations: int = SOLVER_ITERATIONS
    cone_friction: bool = CONE_FRICTION


def physics_for(gripper: GripperSpec) -> PhysicsSettings:
    """The default settings with solver iterations for ``gripper``'s closing force: SOLVER_ITERATIONS up to
    REFERENCE_FORCE, in proportion above it. At 50 iterations the solver does not converge on a light object
    squeezed by a stronger grip: the Franka hand's 70 N dropped the 50 g household butter box when shaken at 22 of
    32 top-down draws, a slip no real hand has; 88 iterations drop it once, as 40 N at 50 do (docs/trials.md)."""
    iterations = max(SOLVER_ITERATIONS, math.ceil(SOLVER_ITERATIONS * gripper.closing_force / REFERENCE_FORCE))
    return PhysicsSettings(solver_iterations=iterations)


class SimWorld:
    """A pybullet client with one gripper and at most one object loaded."""

    def __init__(self, gripper: GripperSpec, physics: PhysicsSettings | None = None):
        self.spec = gripper
        self.physics = physics_for(gripper) if physics is None else physics
        remove_orphan_hull_files()
        self.com = np.zeros(3)
        self._connect()  # also sets self.obj: int | None
        self._hulls: str | None = None  # the loaded object's hulls file (kept while it is loaded)
        self._shape, self._centroid, self._mass, self._pieces = -1, np.zeros(3), 0.0, []
        self.object_friction = 1.0

    def _connect(self) -> None:
        self.client = pb.connect(pb.DIRECT)
        physics = self.physics
        pb.setTimeStep(physics.time_step, physicsClientId=self.client)
        pb.setPhysicsEngineParameter(numSolverIterations=physics.solver_iterations, deterministicOverlappingPairs=1,
                                     enableConeFriction=int(physics.cone_friction), enableFileCaching=0,
                                     physicsClientId=self.client)
        self.gripper, self.constraint = self._build_gripper()
        self.obj, self._rebuilds = None, 0

    def close(self) -> None:
        self._unload()
        pb.disconnect(physicsClientId=self.client)

    def _palm_shape(self) -> int:
        g, c = self.spec, self.client
        half = [g.palm_depth / 2, g.max_opening / 2 + g.finger_thickness, g.palm_height / 2]
        if g.name != FRANKA_HAND:
            return pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, collisionFramePosition=[-g.palm_depth / 2,
                                           0, 0], physicsClientId=c)
        import pybullet_data

        hand = str(Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision" / "hand.obj")
        # the hand's frame in ours: u = z - (tip - finger_length), v = y, t = -x (core.sampling.franka_hand_box)
        axes = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # columns: hand x, y, z in ours
        return pb.createCollisionShapeArray(
            [pb.GEOM_BOX, pb.GEOM_MESH], halfExtents=[half, [0, 0, 0]], fileNames=["", hand],
            meshScales=[[1, 1, 1], [1, 1, 1]],
            collisionFramePositions=[[-g.palm_depth / 2, 0, 0], [g.finger_length - FRANKA_FINGERTIP_Z, 0, 0]],
            collisionFrameOrientations=[[0, 0, 0, 1], quat_from_matrix(axes)], physicsClientId=c)

    def _build_gripper(self) -> tuple[int, int]:
        g, c = self.spec, self.client
        palm = self._palm_shape()
        finger = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[g.finger_length / 2, g.finger_thickness / 2,
                                         g.finger_height / 2], physicsClientId=c)
        side = g.max_opening / 2 + g.finger_thickness / 2
        body = pb.createMultiBody(
            baseMass=0.5, baseCollisionShapeIndex=palm, baseVisualShapeIndex=-1,
            baseInertialFramePosition=[0, 0, 0],
            linkMasses=[g.finger_mass] * 2, linkCollisionShapeIndices=[finger] * 2, linkVisualShapeIndices=[-1] * 2,
            linkPositions=[[g.finger_length / 2, -side, 0], [g.finger_length / 2, side, 0]],
            linkOrientations=[[0, 0, 0, 1]] * 2, linkInertialFramePositions=[[0, 0, 0]] * 2,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * 2, linkParentIndices=[0, 0],
            linkJointTypes=[pb.JOINT_PRISMATIC] * 2, linkJointAxis=[[0, 1, 0], [0, -1, 0]], physicsClientId=c)
        for link in (0, 1):
            pb.changeDynamics(body, link, lateralFriction=g.friction, jointLowerLimit=0.0,
                              jointUpperLimit=g.max_opening / 2, physicsClientId=c)
            pb.setJointMotorControl2(body, link, pb.VELOCITY_CONTROL, force=0, physicsClientId=c)
        coupling = pb.createConstraint(body, 0, body, 1, pb.JOINT_GEAR, [0, 1, 0], [0, 0, 0], [0, 0, 0],
                                       physicsClientId=c)  # the fingers move as one, like the Panda's mimic joint
        pb.changeConstraint(coupling, gearRatio=-1, maxForce=FINGER_COUPLING_FORCE, erp=0.8, physicsClientId=c)
        constraint = pb.createConstraint(body, -1, -1, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0], [0, 0, 0],
                                         physicsClientId=c)
        pb.changeConstraint(constraint, maxForce=2000, physicsClientId=c)
        return body, constraint

    def set_finger_friction(self, friction: float) -> None:
        for link in (0, 1):
            pb.changeDynamics(self.gripper, link, lateralFriction=friction, physicsClientId=self.client)

    def load_object(self, pieces: list[np.ndarray], volume: float, density: float, friction: float = 1.0) -> None:
        """Replace the object by one rigid body whose collision shape is the compound of convex ``pieces``
        ((k, 3) vertex arrays in the mesh frame; each piece is the hull of its points), of mass ``density`` (kg/m^3)
        times ``volume`` (m^3) clipped to [MIN_MASS, MAX_MASS].

        One body, not a body per piece joined by fixed joints: pybullet's fixed-joint chain lets the pieces give
        way under the fingers (a box cut into three slabs dropped a quarter of its centred grasps;
        tests/test_sim.py holds the cut box to the whole one).

        The object's own friction coefficient is 1: Bullet multiplies the two bodies' coefficients at a contact,
        so each finger contact has the pads' coefficient (``gripper.friction``), as the spec says; an object's own
        ``friction`` (a folder manifest's) multiplies it.
        """
        self._unload()
        self.object_friction = friction
        if self._rebuilds > PAYLOAD_REBUILDS_PER_CLIENT:
            pb.disconnect(physicsClientId=self.client)
            self._connect()
        self._centroid = np.vstack(pieces).mean(axis=0)
        self._mass = object_mass(density, volume)
        self._pieces = [p - self._centroid for p in pieces]
        path = _write_hulls(self._pieces)
        try:
            self._shape = pb.createCollisionShape(pb.GEOM_MESH, fileName=path, physicsClientId=self.client)
            self._make_body(self._centroid, self._mass)
        finally:
            Path(path).unlink(missing_ok=True)

    def carry_payload(self, centre: np.ndarray | None, mass: float = 0.0) -> None:
        """Rebuild the loaded object's body at rest: with ``centre`` None, the object itself (its mass, its centre
        of mass at the pieces' centroid); otherwise a payload of ``mass`` kg whose centre of mass is ``centre``
        (3,) in the mesh frame, with the inertia of a solid sphere of radius PAYLOAD_RADIUS, so gravity and shaking
        load the contacts as a weight held at that point would (``sim.load: grasp``, docs/trials.md).

        pybullet reads a mesh shape's file again for every body made from it: the first rebuild of an object
        writes its pieces to a file that stays until the object is unloaded. A rebuild costs about 1 ms and leaves
        about 5 kB that only a new client frees: the next object loaded after PAYLOAD_REBUILDS_PER_CLIENT rebuilds
        gets a new client."""
        if self._hulls is None:
            self._hulls = _write_hulls(self._pieces)
            self._shape = pb.createCollisionShape(pb.GEOM_MESH, fileName=self._hulls, physicsClientId=self.client)
        pb.removeBody(self.obj, physicsClientId=self.client)
        self._rebuilds += 1
        if centre is None:
            self._make_body(self._centroid, self._mass)
        else:
            self._make_body(np.asarray(centre, dtype=np.float64), mass, 0.4 * mass * PAYLOAD_RADIUS ** 2)

    def _make_body(self, com: np.ndarray, mass: float, inertia: float | None = None) -> None:
        """The object's body from the loaded shape, its mesh frame at the world origin, its centre of mass at
        ``com`` (3,) (mesh frame), with ``inertia`` (kg m^2, about every axis) or pybullet's from the shape."""
        c = self.client
        self.obj = pb.createMultiBody(baseMass=mass, baseCollisionShapeIndex=self._shape,
                                      basePosition=self._centroid.tolist(),
                                      baseInertialFramePosition=(com - self._centroid).tolist(),
                                      useMaximalCoordinates=True, physicsClientId=c)
        self.com = com
        pb.changeDynamics(self.obj, -1, lateralFriction=self.object_friction, physicsClientId=c)
        if inertia is not None:
            # with the mass: alone, the inertia leaves a maximal-coordinates body with mass 0 (static)
            pb.changeDynamics(self.obj, -1, mass=mass, localInertiaDiagonal=[inertia] * 3, physicsClientId=c)

    def _unload(self) -> None:
        if self.obj is not None:
            pb.removeBody(self.obj, physicsClientId=self.client)
            self.obj = None
        if self._hulls is not None:
            Path(self._hulls).unlink(missing_ok=True)
            self._hulls = None

    def object_pose(self) -> np.ndarray:
        """(4, 4) world pose of the object's mesh frame."""
        pos, quat = pb.getBasePositionAndOrientation(self.obj, physicsClientId=self.client)
        pose = matrix_from_pose(pos, quat)
        pose[:3, 3] -= apply_rotation(pose[:3, :3], self.com)
        return pose

    def gripper_pose(self) -> np.ndarray:
        pos, quat = pb.getBasePositionAndOrientation(self.gripper, physicsClientId=self.client)
        return matrix_from_pose(pos, quat)


def object_mass(density: float, volume: float) -> float:
    """kg of a simulated object of ``density`` (kg/m^3) and ``volume`` (m^3), clipped to [MIN_MASS, MAX_MASS]."""
    return float(np.clip(density * volume, MIN_MASS, MAX_MASS))


HULLS_PREFIX = "onepiece-hulls-"  # then the writing process's id: onepiece-hulls-<pid>-<random>.obj


def _write_hulls(pieces: list[np.ndarray]) -> str:
    """An OBJ of convex pieces ((k, 3) vertices, k >= 4) for pybullet, which builds compounds only from files:
    one ``o`` group per hull, fan faces (a hull needs only its points). This process writes it itself, in a new
    private file (``mkstemp``: mode 0600, a name nobody else holds) in the temporary folder; the world deletes it
    as soon as pybullet has read it (or, once payload rebuilds read it again, when the object is unloaded): no
    file from a dataset or a user reaches pybullet this way. A worker killed meanwhile (as Ray and the fault
    tests kill them) leaves that one file; the next world removes it (:func:`remove_orphan_hull_files`).
    Returns its path."""
    lines, first = [], 1
    for k, piece in enumerate(pieces):
        lines.append(f"o piece{k}")
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in piece]
        lines += [f"f {first} {first + j} {first + j + 1}" for j in range(1, len(piece) - 1)]
        first += len(piece)
    handle, path = tempfile.mkstemp(prefix=f"{HULLS_PREFIX}{os.getpid()}-", suffix=".obj")
    with os.fdopen(handle, "w") as out:
        out.write("\n".join(lines) + "\n")
    return path


def remove_orphan_hull_files(folder: str | os.PathLike | None = None) -> int:
    """Delete the hull files (:func:`_write_hulls`) in ``folder`` (default: the temporary folder) whose writing
    process no longer runs; returns how many. A live process's file, or one whose name has no process id, stays."""
    removed = 0
    for path in Path(folder or tempfile.gettempdir()).glob(f"{HULLS_PREFIX}*-*.obj"):
        pid = path.name[len(HULLS_PREFIX):].split("-", 1)[0]
        if pid.isdigit() and not _process_runs(int(pid)):
            path.unlink(missing_ok=True)
            removed += 1
    return removed


def _process_runs(pid: int) -> bool:
    try:
        os.kill(pid, 0)  # signal 0: only asks whether the process exists
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    return True


_WORLDS: dict[GripperSpec, SimWorld] = {}


def process_world(gripper: GripperSpec) -> SimWorld:
    """The one pybullet client of this process for ``gripper`` (created on first use, then reused)."""
    if gripper not in _WORLDS:
        _WORLDS[gripper] = SimWorld(gripper)
    return _WORLDS[gripper]
