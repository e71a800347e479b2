"""One pybullet DIRECT client per process, reused across objects: a floating parallel-jaw gripper built from
:class:`GripperSpec` and one object at a time.

The gripper base frame is the gripper frame (origin at the palm centre, on the palm face; its inertial frame
coincides). The base is a box (the palm) held by a fixed constraint that trials move; two prismatic fingers close
along v with a force limit. The object's frame is its mesh frame; it starts at the world origin, so candidate
poses (gripper in the object frame) are also world poses at the start of a trial.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from onepiece_dist.spec import GripperSpec

TIME_STEP = 1.0 / 240.0
SOLVER_ITERATIONS = 50
DENSITY = 150.0  # kg/m^3, as ACRONYM
MIN_MASS, MAX_MASS = 0.05, 2.0  # kg


@dataclass(frozen=True)
class BodyIds:
    gripper: int
    constraint: int
    obj: int
    com: np.ndarray  # (3,) object centre of mass in its mesh frame


def quat_from_matrix(rot: np.ndarray) -> list[float]:
    """(3, 3) rotation -> pybullet quaternion [x, y, z, w]."""
    m = rot
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = 0.25 * s, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    return [float(x) for x in q]


def matrix_from_pose(position, quaternion) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = np.reshape(pb.getMatrixFromQuaternion(quaternion), (3, 3))
    pose[:3, 3] = position
    return pose


class SimWorld:
    """A pybullet client with one gripper and at most one object loaded."""

    def __init__(self, gripper: GripperSpec):
        self.spec = gripper
        self.client = pb.connect(pb.DIRECT)
        pb.setTimeStep(TIME_STEP, physicsClientId=self.client)
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, deterministicOverlappingPairs=1,
                                     physicsClientId=self.client)
        self.gripper, self.constraint = self._build_gripper()
        self.obj: int | None = None
        self.com = np.zeros(3)

    def close(self) -> None:
        pb.disconnect(physicsClientId=self.client)

    def _build_gripper(self) -> tuple[int, int]:
        g, c = self.spec, self.client
        palm = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[g.palm_depth / 2, g.max_opening / 2 +
                                       g.finger_thickness, g.palm_height / 2],
                                       collisionFramePosition=[-g.palm_depth / 2, 0, 0], physicsClientId=c)
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
        constraint = pb.createConstraint(body, -1, -1, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0], [0, 0, 0],
                                         physicsClientId=c)
        pb.changeConstraint(constraint, maxForce=2000, physicsClientId=c)
        return body, constraint

    def set_finger_friction(self, friction: float) -> None:
        for link in (0, 1):
            pb.changeDynamics(self.gripper, link, lateralFriction=friction, physicsClientId=self.client)

    def load_object(self, pieces: list[np.ndarray], volume: float, friction: float) -> None:
        """Replace the object by a compound of convex ``pieces`` ((k, 3) vertex arrays in the mesh frame)."""
        if self.obj is not None:
            pb.removeBody(self.obj, physicsClientId=self.client)
        c = self.client
        allpts = np.vstack(pieces)
        self.com = allpts.mean(axis=0)
        shapes = [pb.createCollisionShape(pb.GEOM_MESH, vertices=(p - self.com).tolist(), physicsClientId=c)
                  for p in pieces]
        mass = float(np.clip(DENSITY * volume, MIN_MASS, MAX_MASS)) / len(shapes)
        extra = len(shapes) - 1  # a compound: one convex piece per link, welded by fixed joints
        self.obj = pb.createMultiBody(
            baseMass=mass, baseCollisionShapeIndex=shapes[0], basePosition=self.com.tolist(),
            linkMasses=[mass] * extra, linkCollisionShapeIndices=shapes[1:], linkVisualShapeIndices=[-1] * extra,
            linkPositions=[[0, 0, 0]] * extra, linkOrientations=[[0, 0, 0, 1]] * extra,
            linkInertialFramePositions=[[0, 0, 0]] * extra, linkInertialFrameOrientations=[[0, 0, 0, 1]] * extra,
            linkParentIndices=[0] * extra, linkJointTypes=[pb.JOINT_FIXED] * extra,
            linkJointAxis=[[0, 0, 1]] * extra, physicsClientId=c)
        for link in range(-1, extra):
            pb.changeDynamics(self.obj, link, lateralFriction=friction, physicsClientId=c)

    def object_pose(self) -> np.ndarray:
        """(4, 4) world pose of the object's mesh frame."""
        pos, quat = pb.getBasePositionAndOrientation(self.obj, physicsClientId=self.client)
        pose = matrix_from_pose(pos, quat)
        pose[:3, 3] -= pose[:3, :3] @ self.com
        return pose

    def gripper_pose(self) -> np.ndarray:
        pos, quat = pb.getBasePositionAndOrientation(self.gripper, physicsClientId=self.client)
        return matrix_from_pose(pos, quat)


_WORLDS: dict[GripperSpec, SimWorld] = {}


def process_world(gripper: GripperSpec) -> SimWorld:
    """The one pybullet client of this process for ``gripper`` (created on first use, then reused)."""
    if gripper not in _WORLDS:
        _WORLDS[gripper] = SimWorld(gripper)
    return _WORLDS[gripper]
