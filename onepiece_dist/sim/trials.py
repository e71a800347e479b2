"""Grasp trials in pybullet (docs/trials.md).

*extract*: gripper at the candidate, gravity off, fingers close at constant speed under a force limit until they
stall, then settle; the settled object pose relative to the gripper and the final width are recorded. Candidates
that start in collision, or whose fingers do not both touch the object, are dropped with a reason.
*label*: extract, then gravity on, lift and shake; success = both fingers still touch the object.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from onepiece_dist.core.frames import invert_poses
from onepiece_dist.sim.world import TIME_STEP, SimWorld, quat_from_matrix

CLOSE_SPEED = 0.25  # m/s per finger
SETTLE_TIME = 0.05  # s after the fingers stall
STALL_SPEED = 2e-3  # m/s
CHECK_EVERY = 4  # steps between stall checks
MAX_SHIFT = 0.1  # m: an object that moves further has flown off (invalid trial)
LIFT_HEIGHT, LIFT_TIME = 0.1, 0.3
SHAKE_AMPLITUDE, SHAKE_PERIOD, SHAKES = 0.02, 0.15, 2
DROP_CHECK_EVERY = 12  # steps between drop checks while lifting and shaking

OUTCOMES = ("ok", "start_collision", "no_contact", "invalid")


@dataclass(frozen=True)
class TrialBatch:
    """outcome (n,) int8 index into OUTCOMES; settled_pose (n, 4, 4) gripper pose in the object frame after
    closing; width (n,) final opening (m); shift (n,) object displacement during closing (m); steps (n,)."""

    outcome: np.ndarray
    settled_pose: np.ndarray
    width: np.ndarray
    shift: np.ndarray
    steps: np.ndarray
    success: np.ndarray | None = None


def place(world: SimWorld, pose: np.ndarray) -> None:
    """Object back at the origin at rest; gripper open at ``pose`` (gripper frame -> world)."""
    c, g = world.client, world.gripper
    pb.resetBasePositionAndOrientation(world.obj, world.com.tolist(), [0, 0, 0, 1], physicsClientId=c)
    pb.resetBaseVelocity(world.obj, [0, 0, 0], [0, 0, 0], physicsClientId=c)
    move_gripper(world, pose, reset=True)
    for link in (0, 1):
        pb.resetJointState(g, link, 0.0, 0.0, physicsClientId=c)
        pb.setJointMotorControl2(g, link, pb.VELOCITY_CONTROL, targetVelocity=0, force=0, physicsClientId=c)


def move_gripper(world: SimWorld, pose: np.ndarray, reset: bool = False) -> None:
    """Drive the holding constraint to ``pose``; with ``reset`` also teleport the gripper there."""
    quat = quat_from_matrix(pose[:3, :3])
    base = pose[:3, 3].tolist()
    if reset:
        pb.resetBasePositionAndOrientation(world.gripper, base, quat, physicsClientId=world.client)
        pb.resetBaseVelocity(world.gripper, [0, 0, 0], [0, 0, 0], physicsClientId=world.client)
    pb.changeConstraint(world.constraint, jointChildPivot=base, jointChildFrameOrientation=quat, maxForce=2000,
                        physicsClientId=world.client)


def close_fingers(world: SimWorld) -> int:
    """Close until both fingers stall (or reach their limit), then settle. Returns the steps taken."""
    c, g, spec = world.client, world.gripper, world.spec
    for link in (0, 1):  # position control to "fully closed": the target doubles as the joint limit
        pb.setJointMotorControl2(g, link, pb.POSITION_CONTROL, targetPosition=spec.max_opening / 2,
                                 force=spec.closing_force, maxVelocity=CLOSE_SPEED, physicsClientId=c)
    max_steps = int((spec.max_opening / 2 / CLOSE_SPEED + 0.1) / TIME_STEP)
    steps = 0
    while steps < max_steps:
        for _ in range(CHECK_EVERY):
            pb.stepSimulation(physicsClientId=c)
        steps += CHECK_EVERY
        if steps > 2 * CHECK_EVERY and _stalled(world):
            break
    settle = int(SETTLE_TIME / TIME_STEP)
    for _ in range(settle):
        pb.stepSimulation(physicsClientId=c)
    return steps + settle


def _stalled(world: SimWorld) -> bool:
    states = pb.getJointStates(world.gripper, [0, 1], physicsClientId=world.client)
    return all(abs(s[1]) < STALL_SPEED for s in states)


def finger_contacts(world: SimWorld) -> tuple[bool, bool]:
    c = world.client
    return tuple(bool(pb.getContactPoints(world.gripper, world.obj, linkIndexA=link, physicsClientId=c))
                 for link in (0, 1))


def starts_in_collision(world: SimWorld, tolerance: float = 1e-3) -> bool:
    pb.performCollisionDetection(physicsClientId=world.client)
    points = pb.getContactPoints(world.gripper, world.obj, physicsClientId=world.client)
    return any(p[8] < -tolerance for p in points)


def extract_trial(world: SimWorld, pose: np.ndarray) -> tuple[int, np.ndarray, float, float, int]:
    """One extract trial. Returns (outcome index, settled gripper pose in object frame, width, shift, steps)."""
    pb.setGravity(0, 0, 0, physicsClientId=world.client)
    place(world, pose)
    if starts_in_collision(world):
        return 1, pose, np.nan, 0.0, 0
    steps = close_fingers(world)
    obj = world.object_pose()
    shift = float(np.linalg.norm(obj[:3, 3]))
    if not np.all(np.isfinite(obj)) or shift > MAX_SHIFT:
        return 3, pose, np.nan, shift, steps
    if not all(finger_contacts(world)):
        return 2, pose, np.nan, shift, steps
    q = [s[0] for s in pb.getJointStates(world.gripper, [0, 1], physicsClientId=world.client)]
    settled = invert_poses(obj) @ world.gripper_pose()
    return 0, settled, world.spec.max_opening - q[0] - q[1], shift, steps


def lift_and_shake(world: SimWorld, start: np.ndarray) -> bool:
    """After closing: gravity on, lift, shake along the world axes; success = both fingers still touch.

    Exits early (failure) as soon as a periodic check finds a finger without contact.
    """
    c = world.client
    pb.setGravity(0, 0, -9.81, physicsClientId=c)
    quat = quat_from_matrix(start[:3, :3])
    for step, offset in enumerate(_trajectory() + start[:3, 3]):
        pb.changeConstraint(world.constraint, jointChildPivot=offset.tolist(), jointChildFrameOrientation=quat,
                            maxForce=2000, physicsClientId=c)
        pb.stepSimulation(physicsClientId=c)
        if step % DROP_CHECK_EVERY == DROP_CHECK_EVERY - 1 and not any(finger_contacts(world)):
            return False
    obj = world.object_pose()
    return bool(np.all(np.isfinite(obj)) and all(finger_contacts(world)))


@functools.cache
def _trajectory() -> np.ndarray:
    """(steps, 3) world offsets of the gripper: lift, then shakes along x and y at the lifted height."""
    lift_steps = int(LIFT_TIME / TIME_STEP)
    lift = np.zeros((lift_steps, 3))
    lift[:, 2] = np.linspace(0, LIFT_HEIGHT, lift_steps)
    t = np.arange(int(SHAKES * SHAKE_PERIOD / TIME_STEP)) * TIME_STEP
    wave = SHAKE_AMPLITUDE * np.sin(2 * np.pi * t / SHAKE_PERIOD)
    shakes = [np.c_[wave, np.zeros_like(wave), np.full_like(wave, LIFT_HEIGHT)],
              np.c_[np.zeros_like(wave), wave, np.full_like(wave, LIFT_HEIGHT)]]
    return np.vstack([lift, *shakes])


def run_trials(world: SimWorld, poses: np.ndarray, label: bool = False) -> TrialBatch:
    """Extract (and optionally label) every candidate pose (n, 4, 4) on the loaded object."""
    n = len(poses)
    outcome, steps = np.zeros(n, np.int8), np.zeros(n, np.int64)
    settled, width, shift = poses.copy(), np.full(n, np.nan), np.zeros(n)
    success = np.zeros(n, bool) if label else None
    for i, pose in enumerate(poses):
        outcome[i], settled[i], width[i], shift[i], steps[i] = extract_trial(world, pose)
        if label and outcome[i] == 0:
            success[i] = lift_and_shake(world, world.gripper_pose())
    return TrialBatch(outcome, settled, width, shift, steps, success)
