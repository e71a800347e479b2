"""The network's first grasps checked before the robot moves (issue 55: its scores cannot tell the surer of its
best grasps apart). Each is executed by the pick protocol, ``draws`` times with the protocol's pose and friction
noise, on the shape the view implies (core.cloud.completion: the observed points and their shadows on the table as
one convex hull, or that hull carved by what the camera saw through; at the protocol's density) in a pick world of
its own, and the grasps are reordered by how often they held there, the network's order on ties. Where the view
holds several objects apart (core.cloud.objects), each grasp is checked on the shape of the one it closes on. The
check knows only the view: the object itself is never seen."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from onepiece_dist.core.cloud.completion import CompletedShape, completed_shape
from onepiece_dist.core.cloud.swept_space import DepthRays
from onepiece_dist.core.frames import compose_poses
from onepiece_dist.plan.planner import GraspCheck, PlannedGrasp, Proposals, Seen
from onepiece_dist.plan.robot import RobotPlan, plan_from_files
from onepiece_dist.specs.job import GripperSpec, SimSpec
from onepiece_dist.specs.plan import PICK_SIM, PlanSpec

CHECK_STREAM = 5959  # the stream of every check's generators, apart from every other stream of a view
_WORLDS: dict = {}  # this process's check worlds, one per gripper, apart from the pick worlds that judge


def check_world(gripper: GripperSpec):
    """This process's pick world for checks with ``gripper`` (created on first use, then reused)."""
    from onepiece_dist.sim.pick import PickWorld

    if gripper not in _WORLDS:
        _WORLDS[gripper] = PickWorld(gripper)
    return _WORLDS[gripper]


def check_shape(seen: Seen, shape: str = "hull", points: np.ndarray | None = None) -> CompletedShape | None:
    """The ``shape`` (PlanSpec.check_shape) ``seen`` implies of the object (core.cloud.completion; its ``points``,
    default all of the view's object points): the hull, mirrored, or carved by what the camera saw through where
    its position is known; None without a support plane or a volume."""
    if seen.plane is None:
        return None
    rays = DepthRays.of(seen.cloud, seen.viewpoint) if shape == "carved" and seen.viewpoint is not None else None
    return completed_shape(seen.objects if points is None else points, seen.plane, rays, mirror=shape == "mirrored")


def held_draws(shape: CompletedShape | None, poses: np.ndarray, gripper: GripperSpec, sim: SimSpec, draws: int,
               rng: np.random.Generator) -> np.ndarray | None:
    """(n, draws) bool: whether each of ``draws`` executions of each of ``poses`` (n, 4, 4; the cloud's frame)
    held on ``shape`` standing on a pick world's table; None where there is no shape."""
    held = shape_draws(shape, gripper, sim, draws, rng)
    return None if held is None else np.array([held(pose) for pose in poses], dtype=bool).reshape(len(poses), draws)


def shape_draws(shape: CompletedShape | None, gripper: GripperSpec, sim: SimSpec, draws: int,
                rng: np.random.Generator) -> Callable[..., list[bool]] | None:
    """``shape`` loaded on this process's check world, and what executes one pose (4, 4; the cloud's frame) on it
    up to ``draws`` times from ``rng`` (whether each held; fewer where its ``settled`` says the draws so far
    decide: settled_against); None where there is no shape."""
    from onepiece_dist.sim.trials import LabelNoise

    if shape is None:
        return None
    world = check_world(gripper)
    world.load_object(list(shape.pieces), shape.volume, sim.density)
    noise, rest = LabelNoise.from_spec(sim), np.eye(4)

    def held(pose: np.ndarray, settled: Callable[[list[bool]], bool] | None = None) -> list[bool]:
        return protocol_draws(world, compose_poses(shape.to_plane, pose), rest, noise, rng, draws, settled)

    return held


def protocol_draws(world, grasp: np.ndarray, resting: np.ndarray, noise, rng: np.random.Generator, draws: int,
                   settled: Callable[[list[bool]], bool] | None = None) -> list[bool]:
    """Whether each of ``draws`` executions of ``grasp`` by the pick protocol (sim.pick.execute_pick) held, fewer
    where ``settled`` says those so far decide. Where every trial must hold, the nominal trial (the same at every
    draw: nothing is drawn for it) is executed once: where it fails, no draw can hold; where it holds, each draw
    executes the perturbed trials alone, until one fails, drawing what execute_pick draws."""
    from onepiece_dist.sim.pick import execute_pick, execute_trial

    if not noise.every_trial:
        return drawn(lambda: execute_pick(world, grasp, resting, noise, rng).success, draws, settled)
    if execute_trial(world, grasp, resting, noise, rng, perturbed=False):
        return [False] * draws

    def perturbed_held() -> bool:
        return all(execute_trial(world, grasp, resting, noise, rng, perturbed=True) == ""
                   for _ in range(noise.trials - 1))

    return drawn(perturbed_held, draws, settled)


def drawn(draw: Callable[[], bool], draws: int, settled: Callable[[list[bool]], bool] | None = None) -> list[bool]:
    """``draw()``'s outcomes, ``draws`` of them, or fewer where ``settled`` says those so far decide."""
    outcomes: list[bool] = []
    while len(outcomes) < draws and not (settled is not None and settled(outcomes)):
        outcomes.append(draw())
    return outcomes


def settled_against(earlier: np.ndarray | None, draws: int) -> Callable[[list[bool]], bool] | None:
    """None (every draw) unless ``earlier`` holds the shares of the grasps ranked before the last one checked:
    then whether the draws so far settle its place among them (it passes a grasp only by holding more often,
    ties keep the network's order), so the rest cannot move it."""
    if earlier is None:
        return None

    def settled(outcomes: list[bool]) -> bool:
        low, high = sum(outcomes) / draws, (sum(outcomes) + draws - len(outcomes)) / draws
        return all(low > share or high <= share for share in earlier)

    return settled


def held_shares(shape: CompletedShape | None, poses: np.ndarray, gripper: GripperSpec, sim: SimSpec, draws: int,
                rng: np.random.Generator) -> np.ndarray | None:
    """(n,) the share of ``draws`` executions of each of ``poses`` that held on ``shape`` (held_draws)."""
    held = held_draws(shape, poses, gripper, sim, draws, rng)
    return None if held is None else np.mean(held, axis=1, dtype=np.float64)


def checked(ranked: tuple[PlannedGrasp, ...], shape: CompletedShape | None, gripper: GripperSpec, sim: SimSpec,
            draws: int, rng: np.random.Generator, later: int = 0) -> tuple[PlannedGrasp, ...]:
    """``ranked`` reordered by how often each held on ``shape`` (the network's order on ties), ranks numbered
    again; unchanged where there is no shape to check on (lazily: ``lazy_order``; its last ``later`` checked only
    where none before held every draw)."""
    if len(ranked) < 2:
        return ranked
    held = shape_draws(shape, gripper, sim, draws, rng)
    return ranked if held is None else _checked_with(ranked, lambda k: held, draws, later)


def checked_apart(ranked: tuple[PlannedGrasp, ...], shapes: list[CompletedShape | None], gripper: GripperSpec,
                  sim: SimSpec, draws: int, rng: np.random.Generator, later: int = 0) -> tuple[PlannedGrasp, ...]:
    """``ranked`` reordered by how often each held on its own shape (``shapes``, one a grasp: the object it closes
    on), the network's order on ties; unchanged where a grasp has no shape to check on (lazily:
    ``lazy_order``, as ``checked``)."""
    if len(ranked) < 2 or any(shape is None for shape in shapes):
        return ranked
    return _checked_with(ranked, lambda k: shape_draws(shapes[k], gripper, sim, draws, rng), draws, later)


def _checked_with(ranked: tuple[PlannedGrasp, ...], held_of: Callable[[int], Callable[..., list[bool]]],
                  draws: int, later: int = 0) -> tuple[PlannedGrasp, ...]:
    """``ranked`` reordered lazily (lazy_order) by the draws ``held_of(k)`` executes of each grasp k, each
    checked grasp with how many of its draws held (PlannedGrasp.held)."""
    executed: dict[int, list[bool]] = {}

    def share(k: int, earlier: np.ndarray | None) -> float:
        executed[k] = held_of(k)(ranked[k].pose, settled_against(earlier, draws))
        return share_of(executed[k], draws)

    order = lazy_order(len(ranked) - later, share, later)
    annotated = tuple(dataclasses.replace(g, held=(sum(executed[k]), len(executed[k]))) if k in executed else g
                      for k, g in enumerate(ranked))
    return annotated if order is None else _in_order(annotated, order)


def share_of(outcomes: list[bool], draws: int) -> float:
    """The share of ``draws`` that held, a draw not taken counted as failed (where settled_against stopped, this
    keeps every comparison the draws settled)."""
    return sum(outcomes) / draws


def lazy_order(count: int, share: Callable[[int, np.ndarray | None], float], later: int = 0) -> np.ndarray | None:
    """The order of ``count`` ranked grasps by ``share(k, earlier)`` of each, asked in rank order; None (the
    network's order) where the first held every draw: no later grasp can pass it (ties keep the network's order),
    so the rest keep the network's order too and the check costs a third of its draws. The last grasp is given
    the ``earlier`` shares and stops drawing once its place among them is settled. Either way the order is what
    executing every draw would give: each grasp's draws come from the stream in rank order, and only draws after
    every other grasp's are left out. Where none of the ``count`` held every draw, up to ``later`` more are asked
    in rank order (every draw) until one does; the order then covers every grasp asked."""
    first = share(0, None)
    if first >= 1.0:
        return None
    shares = [first]
    for k in range(1, count):
        shares.append(share(k, np.array(shares) if k == count - 1 and not later else None))
    while len(shares) < count + later and max(shares) < 1.0:
        shares.append(share(len(shares), None))
    return np.argsort(-np.array(shares), kind="stable")


def _in_order(ranked: tuple[PlannedGrasp, ...], order: np.ndarray) -> tuple[PlannedGrasp, ...]:
    """``ranked`` in ``order`` (the grasps it covers), those it does not cover after them in rank order."""
    order = [*order, *range(len(order), len(ranked))]
    return tuple(dataclasses.replace(ranked[i], rank=k + 1) for k, i in enumerate(order))


def check_sim(spec: PlanSpec, sim: SimSpec) -> SimSpec:
    """The protocol ``sim`` the check executes with: at ``spec.check_density`` where set (the shape's mass)."""
    return sim if spec.check_density is None else sim.model_copy(update={"density": spec.check_density})


def view_check(spec: PlanSpec, sim: SimSpec = PICK_SIM, rng: np.random.Generator | None = None) -> GraspCheck:
    """The planner's check (planner.GraspCheck) as ``spec`` asks for it: ``spec.check_draws`` executions of each
    grasp by the ``sim`` protocol (default: the pick benchmark's; its density ``spec.check_density`` where set),
    drawn from ``rng`` (default: seeded by ``spec.seed``)."""
    rng, sim = np.random.default_rng([spec.seed, CHECK_STREAM]) if rng is None else rng, check_sim(spec, sim)

    def check(ranked: tuple[PlannedGrasp, ...], proposals: Proposals, gripper: GripperSpec, later: int = 0
              ) -> tuple[PlannedGrasp, ...]:
        seen = Seen.of(proposals)
        objects = seen.separate()
        if len(objects) == 1:  # one object: its shape from every observed point
            return checked(ranked, check_shape(seen, spec.check_shape), gripper, sim, spec.check_draws, rng, later)
        mine = [g.object for g in ranked]  # the object each closes on, found as it was planned
        shapes = {k: check_shape(seen, spec.check_shape, objects[k]) for k in sorted(set(mine))}  # those grasped
        return checked_apart(ranked, [shapes[k] for k in mine], gripper, sim, spec.check_draws, rng, later)

    return check


def plan_checked(cloud: str | Path, checkpoint: str | Path | None = None, spec: PlanSpec | None = None,
                 intrinsics: str | None = None, depth_scale: float | None = None,
                 viewpoint: tuple[float, float, float] | None = None, camera_pose: str | Path | None = None,
                 workspace: str | None = None, gripper: GripperSpec | None = None) -> RobotPlan:
    """plan.robot.plan_from_files with the first ``spec.check_first`` grasps checked on the shape the view implies
    (the API's and `onepiece grasp`'s planning: onepiece_dist.api.plan_grasps)."""
    spec = spec or PlanSpec()
    check = view_check(spec) if spec.check_first else None
    return plan_from_files(cloud, checkpoint, spec, intrinsics, depth_scale, viewpoint, camera_pose, workspace,
                           gripper, check)
