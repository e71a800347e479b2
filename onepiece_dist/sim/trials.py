"""Grasp trials in pybullet (docs/trials.md).

*extract*: gripper at the candidate, gravity off, fingers close at constant speed under a force limit until they
stall, then settle; the settled object pose relative to the gripper and the final width are recorded. Candidates
that start in collision, or whose fingers do not both touch the object, are dropped with a reason.
*label*: extract, then gravity on, lift, shake linearly and rotationally; success = both fingers still touch the
object; quality = success fraction over K trials with friction and pose noise; the binary label is the nominal
trial's success or, with ``sim.success: every_trial``, success in all K trials.
"""

from __future__ import annotations

import functools
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from onepiece_dist.core import portable
from onepiece_dist.core.frames import apply_rotation, compose_poses, invert_poses, perturb_pose, quat_from_matrix
from onepiece_dist.sim.world import SimWorld
from onepiece_dist.specs.job import SimSpec

CLOSE_SPEED = 0.25  # m/s per finger
SETTLE_TIME = 0.05  # s after the fingers stall
STALL_SPEED = 2e-3  # m/s
CHECK_EVERY = 4  # steps between stall checks
MAX_SHIFT = 0.1  # m: an object that moves further has flown off (invalid trial)
LIFT_HEIGHT, LIFT_TIME = 0.1, 0.15
SHAKE_AMPLITUDE, SHAKE_PERIOD, SHAKES = 0.02, 0.12, 1
ROTATION_AMPLITUDE = np.radians(30.0)  # rotational shake about world z
DROP_CHECK_EVERY = 12  # steps between drop checks while lifting and shaking

OUTCOMES = ("ok", "start_collision", "no_contact", "invalid")


@dataclass(frozen=True)
class TrialBatch:
    """outcome (n,) int8 index into OUTCOMES; settled_pose (n, 4, 4) gripper pose in the object frame after
    closing; width (n,) final opening (m); shift (n,) object displacement during closing (m); steps (n,) closing
    steps. With labels: success (n,) bool, quality (n,) float in [0, 1], slip (n,) object motion in the gripper
    frame while lifting and shaking (m)."""

    outcome: np.ndarray
    settled_pose: np.ndarray
    width: np.ndarray
    shift: np.ndarray
    steps: np.ndarray
    success: np.ndarray | None = None
    quality: np.ndarray | None = None
    slip: np.ndarray | None = None


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
    max_steps = int((spec.max_opening / 2 / CLOSE_SPEED + 0.1) / world.physics.time_step)
    steps = 0
    while steps < max_steps:
        for _ in range(CHECK_EVERY):
            pb.stepSimulation(physicsClientId=c)
        steps += CHECK_EVERY
        if steps > 2 * CHECK_EVERY and _stalled(world):
            break
    settle = int(SETTLE_TIME / world.physics.time_step)
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
    settled = compose_poses(invert_poses(obj), world.gripper_pose())
    return 0, settled, world.spec.max_opening - q[0] - q[1], shift, steps


def lift_and_shake(world: SimWorld, start: np.ndarray, lost_at: list[int] | None = None) -> tuple[bool, float]:
    """After closing: gravity on, lift, shake linearly along world x and y, then rotationally about world z.

    Exits early (failure) when a periodic check finds no finger touching the object; ``lost_at``, when given,
    gets the step at which the object was found lost (the path's length when it was lost only at the end).
    returns : success (both fingers still touch at the end), slip (m) = largest change of the object's position
              in the gripper frame during lifting and shaking
    """
    c = world.client
    pb.setGravity(0, 0, -9.81, physicsClientId=c)
    held = _object_in_gripper(world)
    pivots, orientations = gripper_path(start, world.physics.time_step)
    slip = 0.0
    for step, (pivot, orientation) in enumerate(zip(pivots, orientations, strict=True)):
        pb.changeConstraint(world.constraint, jointChildPivot=pivot, jointChildFrameOrientation=orientation,
                            maxForce=2000, physicsClientId=c)
        pb.stepSimulation(physicsClientId=c)
        if step % DROP_CHECK_EVERY == DROP_CHECK_EVERY - 1:
            slip = max(slip, _distance(_object_in_gripper(world), held))
            if not any(finger_contacts(world)):
                if lost_at is not None:
                    lost_at.append(step)
                return False, slip
    slip = max(slip, _distance(_object_in_gripper(world), held))
    success = bool(np.isfinite(slip) and all(finger_contacts(world)))
    if not success and lost_at is not None:
        lost_at.append(len(pivots))
    return success, slip


def lift_steps(time_step: float) -> int:
    """Steps of the lift before the shakes begin (gripper_path's first part)."""
    return int(round(LIFT_TIME / time_step))


def gripper_path(start: np.ndarray, time_step: float) -> tuple[list, list]:
    """The lift-and-shake path from the gripper pose ``start`` (4, 4): per step of ``time_step`` seconds the
    constraint pivot [x, y, z] and orientation [x, y, z, w], as lists ready for pybullet (built once per trial,
    not per step).

    Every step turns ``start`` about world z by an angle with half-angle cosine c and sine s, so its quaternion
    is (0, 0, s, c) * q_start, written out below.
    """
    offsets, half_cos, half_sin = _trajectory(time_step)
    x, y, z, w = quat_from_matrix(start[:3, :3])
    turned = np.stack([half_cos * x - half_sin * y, half_cos * y + half_sin * x, half_cos * z + half_sin * w,
                       half_cos * w - half_sin * z], axis=1)
    return (start[:3, 3] + offsets).tolist(), turned.tolist()


def _object_in_gripper(world: SimWorld) -> tuple[float, float, float]:
    """Position of the object's mesh-frame origin in the gripper frame (pybullet transform calls, no arrays)."""
    c = world.client
    position, orientation = pb.getBasePositionAndOrientation(world.obj, physicsClientId=c)
    origin = pb.multiplyTransforms(position, orientation, (-world.com).tolist(), (0, 0, 0, 1))[0]
    inverse = pb.invertTransform(*pb.getBasePositionAndOrientation(world.gripper, physicsClientId=c))
    return pb.multiplyTransforms(*inverse, origin, (0, 0, 0, 1))[0]


def _distance(a, b) -> float:
    return float(np.sqrt(sum((x - y) ** 2 for x, y in zip(a, b, strict=True))))


@functools.cache
def _trajectory(dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World offsets (steps, 3) of the gripper, and the cosine and sine (steps,) of half its turn about world z:
    lift; linear shakes along x and y; a rotational shake about z."""
    lift_steps = int(round(LIFT_TIME / dt))
    lift = np.zeros((lift_steps, 3))
    lift[:, 2] = np.linspace(0, LIFT_HEIGHT, lift_steps)
    t = np.arange(int(round(SHAKES * SHAKE_PERIOD / dt))) * dt
    wave = portable.sin(2 * np.pi * t / SHAKE_PERIOD)
    up = np.full_like(wave, LIFT_HEIGHT)
    zeros = np.zeros_like(wave)
    offsets = np.vstack([lift, np.c_[SHAKE_AMPLITUDE * wave, zeros, up], np.c_[zeros, SHAKE_AMPLITUDE * wave, up],
                         np.c_[zeros, zeros, up]])
    angles = np.concatenate([np.zeros(lift_steps + 2 * len(t)), ROTATION_AMPLITUDE * wave])
    sin, cos = portable.sin_cos(angles / 2)
    return offsets, cos, sin


@dataclass(frozen=True)
class LabelNoise:
    """Perturbations of the robust-quality trials: translation (m), rotation (rad), relative friction; and whether
    the binary label asks every trial to hold (``every_trial``) or only the nominal one. Built from the job's
    :class:`SimSpec` by :meth:`from_spec`, the one place its defaults live."""

    trials: int
    translation: float
    rotation: float
    friction: float
    every_trial: bool = False
    payload: float | None = None  # kg at the grasp centre (sim.load: grasp); None: the object's own mass

    @classmethod
    def from_spec(cls, sim: SimSpec) -> LabelNoise:
        return cls(sim.label_trials, sim.pose_noise, sim.rotation_noise, sim.friction_noise,
                   sim.success == "every_trial", sim.load_mass if sim.load == "grasp" else None)


def label_quality(world: SimWorld, pose: np.ndarray, rng: np.random.Generator, noise: LabelNoise) -> float:
    """Success fraction over ``noise.trials - 1`` perturbed label trials (friction and pose noise)."""
    return sum(perturbed_trial(world, pose, rng, noise) for _ in range(noise.trials - 1))


def perturbed_trial(world: SimWorld, pose: np.ndarray, rng: np.random.Generator, noise: LabelNoise) -> bool:
    """One label trial at ``pose`` with pose and friction noise drawn from ``rng``: closed, lifted and shaken."""
    base_friction = world.spec.friction
    world.set_finger_friction(base_friction * max(0.05, 1 + rng.normal(0, noise.friction)))
    try:
        if extract_trial(world, perturb_pose(pose, rng, noise.translation, noise.rotation))[0] == 0:
            return bool(lift_and_shake(world, world.gripper_pose())[0])
        return False
    finally:
        world.set_finger_friction(base_friction)


def label_draws(world: SimWorld, poses: np.ndarray, rngs: list[np.random.Generator], noise: LabelNoise,
                draws: int) -> np.ndarray:
    """(n, draws) bool: the label of each candidate ``poses[i]`` drawn ``draws`` times again, each draw a new
    execution of the protocol (its nominal trial perturbed too, so a repeat is not the same execution), with
    grasp i's draws from ``rngs[i]``: the label's own repeatability (stats.ceiling). What is lifted is what the
    label lifts: the object, or with a payload (sim.load: grasp) the payload at the grasp centre."""
    out = np.zeros((len(poses), draws), dtype=bool)
    for i, pose in enumerate(poses):
        with carrying_load(world, pose, noise):
            for j in range(draws):
                first = perturbed_trial(world, pose, rngs[i], noise)
                if noise.every_trial:
                    out[i, j] = first and label_quality(world, pose, rngs[i], noise) == noise.trials - 1
                else:
                    out[i, j] = first
    return out


@contextmanager
def carrying_load(world: SimWorld, pose: np.ndarray, noise: LabelNoise):
    """The label's load while it is simulated: with a payload (``noise.payload``) the object is rebuilt as a weight
    centred at the grasp centre (the closing region's centre at ``pose``), and restored afterwards."""
    if noise.payload is not None:
        centre = apply_rotation(pose[:3, :3], [world.spec.closing_depth / 2, 0.0, 0.0]) + pose[:3, 3]
        world.carry_payload(centre, noise.payload)
    try:
        yield
    finally:
        if noise.payload is not None:
            world.carry_payload(None)


def run_trials(world: SimWorld, poses: np.ndarray, label: bool = False, noise: LabelNoise | None = None,
               rng: np.random.Generator | None = None) -> TrialBatch:
    """Extract (and optionally label) every candidate pose (n, 4, 4) on the loaded object.

    With ``label``, each held grasp is lifted and shaken once at its candidate pose, plus ``noise.trials - 1``
    perturbed repetitions; ``quality`` = success fraction over all of them; ``success`` = the nominal trial held,
    or with ``noise.every_trial`` all of them did.
    """
    n = len(poses)
    noise = noise or LabelNoise.from_spec(SimSpec())
    rng = rng or np.random.default_rng(0)
    outcome, steps = np.zeros(n, np.int8), np.zeros(n, np.int64)
    settled, width, shift = poses.copy(), np.full(n, np.nan), np.zeros(n)
    success, quality, slip = (np.zeros(n, bool), np.zeros(n), np.full(n, np.nan)) if label else (None,) * 3
    for i, pose in enumerate(poses):
        outcome[i], settled[i], width[i], shift[i], steps[i] = extract_trial(world, pose)
        if label and outcome[i] == 0:
            success[i], quality[i], slip[i] = label_grasp(world, pose, rng, noise)
    return TrialBatch(outcome, settled, width, shift, steps, success, quality, slip)


def label_grasp(world: SimWorld, pose: np.ndarray, rng: np.random.Generator,
                noise: LabelNoise) -> tuple[bool, float, float]:
    """The label trials of the candidate ``pose`` (4, 4), right after its extract trial held: (success, quality,
    slip). The nominal trial lifts and shakes the grasp just closed; with a payload (``noise.payload``) the object
    is rebuilt as a weight centred at the grasp centre (the closing region's centre at ``pose``) and closed on
    again, and the object itself is restored afterwards."""
    with carrying_load(world, pose, noise):
        held = noise.payload is None or extract_trial(world, pose)[0] == 0
        success, slip = lift_and_shake(world, world.gripper_pose()) if held else (False, np.nan)
        quality = (success + label_quality(world, pose, rng, noise)) / noise.trials
    return (quality == 1.0 if noise.every_trial else success), quality, slip
