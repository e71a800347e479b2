"""The network's first grasps checked on the shape one view implies (issue 55): the completed shape is the observed
points and their shadows on the table, in the plane's frame, carved by what the camera saw through (an open box
stays open, a closed one stays whole); a grasp that holds a box there is put before one that closes on air;
without a plane the network's order stands."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.cloud.completion import completed_shape, plane_frame
from onepiece_dist.core.cloud.grasps import SupportPlane
from onepiece_dist.core.cloud.swept_space import DepthRays
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.core.frames import axis_turns
from onepiece_dist.specs.plan import PICK_SIM

FLOOR = SupportPlane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, bool))


def seen_box(size=(0.04, 0.06, 0.08), step=0.004) -> np.ndarray:
    """What a camera above one side sees of a box standing on z = 0: its top face and its -y face."""
    (a, b, c), grid = size, np.arange(0, 1 + 1e-9, step / max(size))
    u, v = np.meshgrid(grid, grid)
    top = np.column_stack([(u.ravel() - 0.5) * a, (v.ravel() - 0.5) * b, np.full(u.size, c)])
    side = np.column_stack([(u.ravel() - 0.5) * a, np.full(u.size, -b / 2), v.ravel() * c])
    return np.vstack([top, side])


def test_the_completed_shape_is_the_seen_points_down_to_the_plane_in_the_planes_frame():
    points = seen_box()
    shape = completed_shape(points, FLOOR)
    assert shape.volume == pytest.approx(0.04 * 0.06 * 0.08, rel=1e-6) and len(shape.pieces) == 1
    assert shape.pieces[0][:, 2].min() == pytest.approx(0.0, abs=1e-12)
    footprint = shape.pieces[0][:, :2]
    assert np.allclose(footprint.min(axis=0) + footprint.max(axis=0), 0, atol=1e-12)  # over a world's table
    turn = np.eye(4)
    turn[:3, :3] = axis_turns(np.array([[1.0, 0.0, 0.0]]), np.array([0.4]))[0]
    turn[:3, 3] = [0.1, -0.2, 0.3]
    tilted = points @ turn[:3, :3].T + turn[:3, 3]
    normal = turn[:3, :3] @ FLOOR.normal
    plane = SupportPlane(normal, -float(normal @ turn[:3, 3]), np.zeros(0, bool))
    again = completed_shape(tilted, plane)
    assert again.volume == pytest.approx(shape.volume, rel=1e-9)  # the same shape, wherever the camera's frame is
    back = tilted @ again.to_plane[:3, :3].T + again.to_plane[:3, 3]
    assert np.allclose(np.sort(back[:, 2]), np.sort(points[:, 2]), atol=1e-9)
    assert np.allclose(plane_frame(FLOOR)[:3, 3], 0)
    assert completed_shape(points[:3], FLOOR) is None and completed_shape(points, plane) is None  # below it


def grid(low: float, high: float, step: float = 0.002) -> np.ndarray:
    return np.arange(low, high + 1e-9, step)


def open_box(side=0.08, wall=0.006, floor=0.006) -> np.ndarray:
    """What a camera straight above sees of an open box of ``side`` standing on z = 0 in a table: the walls' tops,
    the inside of its floor, and the table around it."""
    u, v = np.meshgrid(grid(-0.15, 0.15), grid(-0.15, 0.15))
    u, v = u.ravel(), v.ravel()
    inner, outer = np.maximum(abs(u), abs(v)) < side / 2 - wall, np.maximum(abs(u), abs(v)) < side / 2
    height = np.where(inner, floor, np.where(outer, side, 0.0))
    return np.column_stack([u, v, height])


def inside(shape, points: np.ndarray) -> np.ndarray:
    """(m,) whether each of ``points`` (the plane's frame) lies in one of ``shape``'s convex pieces."""
    from scipy.spatial import Delaunay

    return np.any([Delaunay(piece).find_simplex(points) >= 0 for piece in shape.pieces], axis=0)


def test_the_carved_shape_keeps_an_opening_the_camera_looked_into_and_a_closed_box_whole():
    cloud, eye = open_box(), np.array([0.0, 0.0, 0.6])
    objects = cloud[cloud[:, 2] > 0]
    hull = completed_shape(objects, FLOOR)
    shape = completed_shape(objects, FLOOR, DepthRays.of(cloud, eye))
    assert hull.volume == pytest.approx(0.08**3, rel=0.1)
    walls = 0.08**3 - (0.08 - 0.012) ** 2 * (0.08 - 0.006)
    assert 0.8 * walls < shape.volume < 0.5 * hull.volume  # the walls, the floor a voxel thicker
    assert not inside(shape, np.array([[0.0, 0.0, 0.05], [0.02, -0.01, 0.03]])).any()  # the opening stays open
    assert inside(shape, np.array([[0.037, 0.0, 0.05], [0.0, -0.037, 0.02], [0.01, 0.01, 0.002]])).all()
    again = completed_shape(objects, FLOOR, DepthRays.of(cloud, eye))
    assert all(np.array_equal(a, b) for a, b in zip(again.pieces, shape.pieces, strict=True))
    box = seen_box()
    table = np.column_stack([*(c.ravel() for c in np.meshgrid(grid(-0.2, 0.2), grid(-0.2, 0.2))),
                             np.zeros(201 * 201)])
    whole = completed_shape(box, FLOOR, DepthRays.of(np.vstack([box, table]), np.array([0.0, -0.4, 0.5])))
    assert whole.volume == pytest.approx(0.04 * 0.06 * 0.08, rel=0.15)  # nothing seen through a closed box


def test_the_mirrored_shape_completes_a_can_seen_from_one_side_and_keeps_a_box_whole():
    angle, height = np.meshgrid(np.linspace(np.pi, 2 * np.pi, 60), grid(0.002, 0.1))
    half_can = np.column_stack([0.03 * np.cos(angle.ravel()) + 0.2, 0.03 * np.sin(angle.ravel()) - 0.1,
                                height.ravel()])  # the near half of a can (r 3 cm) a camera at -y sees
    can = np.pi * 0.03**2 * 0.1
    assert completed_shape(half_can, FLOOR).volume == pytest.approx(can / 2, rel=0.03)
    assert completed_shape(half_can, FLOOR, mirror=True).volume == pytest.approx(can, rel=0.03)
    box = completed_shape(seen_box(), FLOOR, mirror=True).volume
    assert 0.04 * 0.06 * 0.08 <= box + 1e-12 and box < 1.25 * 0.04 * 0.06 * 0.08


@pytest.mark.sim
def test_a_grasp_that_holds_the_completed_box_goes_before_one_that_closes_on_air():
    from onepiece_dist.picks.shape_check import checked, held_shares
    from onepiece_dist.plan.planner import PlannedGrasp
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network

    gripper = GraspScorer(shipped_network(), device="cpu").gripper  # the gripper the shipped network plans for
    points = seen_box()
    good = top_down_grasps(points, np.array([0.0, 0.0, -1.0]), gripper)[0]
    air = good.copy()
    air[:3, 3] += [0.15, 0.0, 0.0]
    shape = completed_shape(points, FLOOR)
    shares = held_shares(shape, np.stack([air, good]), gripper, PICK_SIM, 4, np.random.default_rng(0))
    assert shares[0] == 0.0 and shares[1] >= 0.5  # each draw with the protocol's pose and friction noise
    again = held_shares(shape, np.stack([air, good]), gripper, PICK_SIM, 4, np.random.default_rng(0))
    assert np.array_equal(shares, again)
    far = np.array([0.8, 0.6, 0.0])  # a robot's base frame: the object beyond the check world's table
    moved = np.stack([air, good])
    moved[:, :3, 3] += far
    assert held_shares(completed_shape(points + far, FLOOR), moved, gripper, PICK_SIM, 4,
                       np.random.default_rng(0))[1] >= 0.5
    ranked = tuple(PlannedGrasp(k + 1, pose, pose, 0.08, 0.0, score, 100)
                   for k, (pose, score) in enumerate([(air, 0.9), (good, 0.8)]))
    reordered = checked(ranked, shape, gripper, PICK_SIM, 4, np.random.default_rng(0))
    assert [g.score for g in reordered] == [0.8, 0.9] and [g.rank for g in reordered] == [1, 2]
    assert checked(ranked, None, gripper, PICK_SIM, 2, np.random.default_rng(0)) == ranked  # no shape


@pytest.mark.sim
def test_the_check_executes_the_nominal_trial_once_and_draws_what_the_protocol_draws():
    from onepiece_dist.core.frames import compose_poses
    from onepiece_dist.picks.shape_check import check_world, protocol_draws
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.sim.pick import execute_pick
    from onepiece_dist.sim.trials import LabelNoise

    gripper = GraspScorer(shipped_network(), device="cpu").gripper
    points = seen_box()
    shape = completed_shape(points, FLOOR)
    world = check_world(gripper)
    world.load_object(list(shape.pieces), shape.volume, PICK_SIM.density)
    noise, rest, seen = LabelNoise.from_spec(PICK_SIM), np.eye(4), []
    across = top_down_grasps(points, np.array([0.0, 0.0, -1.0]), gripper)[0]
    for height in (0.0, 0.03, 0.04):  # fingers low on the box, near its top, above it (the nominal trial fails)
        pose = across.copy()
        pose[:3, 3] += [0.0, 0.0, height]
        placed = compose_poses(shape.to_plane, pose)
        whole, once = np.random.default_rng(0), np.random.default_rng(0)
        by_protocol = [execute_pick(world, placed, rest, noise, whole).success for _ in range(8)]
        assert protocol_draws(world, placed, rest, noise, once, 8) == by_protocol
        assert once.random() == whole.random()  # the same draws taken from the stream
        seen += by_protocol
    assert any(seen) and not all(seen)


@pytest.mark.sim
def test_the_api_checks_the_first_grasps_and_the_bare_planner_refuses_to_pretend_it_did(tmp_path):
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.errors import SpecError
    from onepiece_dist.plan import GraspScorer, Observation
    from onepiece_dist.plan.planner import plan_grasps as bare_plan
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_plan import _floor

    cloud = tmp_path / "box.npy"
    np.save(cloud, np.vstack([seen_box(), _floor(0.0)]))
    eye = (0.3, -0.3, 0.4)
    plain = plan_grasps(cloud, spec=PlanSpec(top_k=6, check_first=0), viewpoint=eye).plan
    checked = plan_grasps(cloud, spec=PlanSpec(top_k=6, check_first=3, check_draws=2), viewpoint=eye).plan
    key = [g.pose.tobytes() for g in plain.grasps]
    assert sorted(g.pose.tobytes() for g in checked.grasps[:3]) == sorted(key[:3])  # the first three, reordered
    assert [g.pose.tobytes() for g in checked.grasps[3:]] == key[3:]
    assert [g.rank for g in checked.grasps] == list(range(1, 7))
    assert "check" in checked.seconds and "check" not in plain.seconds and not checked.notes
    np.save(tmp_path / "alone.npy", seen_box())
    alone = plan_grasps(tmp_path / "alone.npy", spec=PlanSpec(top_k=6, support_plane="none"), viewpoint=eye).plan
    assert len(alone.notes) == 1 and "the first 3 grasps are in the network's order, not checked" in alone.notes[0]
    scorer = GraspScorer(shipped_network(), device="cpu")
    assert PlanSpec().check_first == 3  # kept by the pick benchmark: the planner without a simulator refuses it
    with pytest.raises(SpecError, match="check_first=3 checks grasps in simulation.*check_first=0"):
        bare_plan(Observation(np.load(cloud), np.array(eye), "box"), scorer, PlanSpec())


@pytest.mark.sim
def test_onepiece_grasp_check_writes_the_checks_seconds(tmp_path):
    import json

    from typer.testing import CliRunner

    from onepiece_dist.cli.main import app
    from tests.test_plan import _floor

    cloud = tmp_path / "box.npy"
    np.save(cloud, np.vstack([seen_box(), _floor(0.0)]))
    ran = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", "0.3,-0.3,0.4", "--top", "4", "--check", "2",
                                   "--check-shape", "carved", "--out", str(tmp_path / "checked"), "--json"])
    assert ran.exit_code == 0, ran.output
    plan = json.loads((tmp_path / "checked" / "grasps.json").read_text())
    assert "check" in plan["seconds"] and len(plan["grasps"]) == 4
    for given, checks in (([], True), (["--check", "0"], False)):  # checked by default; 0: the network's order
        folder = tmp_path / f"default{len(given)}"
        ran = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", "0.3,-0.3,0.4", "--out", str(folder),
                                       *given])
        assert ran.exit_code == 0 and ("check" in json.loads((folder / "grasps.json").read_text())["seconds"]) == checks
        assert ("executed in simulation on the shape the view implies" in ran.output) == checks  # said on stderr
    bad = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", "0.3,-0.3,0.4", "--check", "-1"])
    assert bad.exit_code != 0 and "check_first" in bad.output
    bad = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", "0.3,-0.3,0.4", "--check-shape", "round"])
    assert bad.exit_code != 0 and "check_shape" in bad.output


@pytest.mark.sim
def test_the_best_top_down_grasp_is_checked_beside_the_first_ones_only_when_asked(tmp_path):
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.picks.shape_check import view_check
    from onepiece_dist.plan import GraspScorer, Observation
    from onepiece_dist.plan.planner import best_top_down, checked_first, propose, rank
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_plan import _floor

    points, eye = np.vstack([seen_box(), _floor(0.0)]), (0.3, -0.3, 0.4)
    np.save(tmp_path / "box.npy", points)
    spec = PlanSpec(top_k=10, check_first=3, check_draws=2, check_top_down=True)
    scorer = GraspScorer(shipped_network(), device="cpu")
    proposals = propose(Observation(points, np.array(eye), "box"), scorer.record, spec,
                        np.random.default_rng([spec.seed, 49]))  # the planner's own stream
    best = best_top_down(proposals, scorer.score(proposals.crops), scorer.record)
    assert proposals.top_down == 3 and best is not None
    plain = plan_grasps(tmp_path / "box.npy", spec=spec.model_copy(update={"check_first": 0}), viewpoint=eye).plan
    checked = plan_grasps(tmp_path / "box.npy", spec=spec, viewpoint=eye).plan
    key = [g.pose.tobytes() for g in plain.grasps]
    first = key[:3] + ([] if best.pose.tobytes() in key[:3] else [best.pose.tobytes()])
    assert sorted(g.pose.tobytes() for g in checked.grasps[:len(first)]) == sorted(first)
    assert [g.pose.tobytes() for g in checked.grasps[len(first):]] == [k for k in key[3:] if k not in first][
        :10 - len(first)]
    assert [g.rank for g in checked.grasps] == list(range(1, 11))
    ranked = rank(proposals, scorer.score(proposals.crops), scorer.record, spec)  # a grasp from the rest joins
    moved = checked_first(ranked, proposals, scorer.gripper, 3, view_check(spec), ranked[6])
    assert sorted(g.pose.tobytes() for g in moved[:4]) == sorted(g.pose.tobytes() for g in (*ranked[:3], ranked[6]))
    assert [g.pose.tobytes() for g in moved[4:]] == [g.pose.tobytes() for g in (*ranked[3:6], *ranked[7:])]
    assert [g.rank for g in moved] == list(range(1, 11))
    sampled = propose(Observation(points, np.array(eye), "box"), scorer.record,
                      spec.model_copy(update={"top_down": False}), np.random.default_rng(0))
    assert best_top_down(sampled, scorer.score(sampled.crops), scorer.record) is None  # no top-down grasps


@pytest.mark.sim
def test_the_check_stops_where_the_first_grasp_held_every_draw_none_after_it_can_pass():
    from onepiece_dist.picks.shape_check import checked, held_shares
    from onepiece_dist.plan.planner import PlannedGrasp
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network

    gripper = GraspScorer(shipped_network(), device="cpu").gripper
    points = seen_box()
    good = top_down_grasps(points, np.array([0.0, 0.0, -1.0]), gripper)[1]  # across the wide axis
    air = good.copy()
    air[:3, 3] += [0.15, 0.0, 0.0]
    shape = completed_shape(points, FLOOR)
    assert held_shares(shape, good[None], gripper, PICK_SIM, 4, np.random.default_rng(0))[0] == 1.0
    ranked = tuple(PlannedGrasp(k + 1, pose, pose, 0.08, 0.0, score, 100)
                   for k, (pose, score) in enumerate([(good, 0.9), (air, 0.8), (good, 0.7)]))
    stopped, alone = np.random.default_rng(0), np.random.default_rng(0)
    first_held = checked(ranked, shape, gripper, PICK_SIM, 4, stopped)
    assert [g.score for g in first_held] == [0.9, 0.8, 0.7] and [g.rank for g in first_held] == [1, 2, 3]
    assert [g.held for g in first_held] == [(4, 4), None, None]  # the first held every draw: no other executed
    held_shares(shape, good[None], gripper, PICK_SIM, 4, alone)
    assert stopped.random() == alone.random()  # only the first grasp's draws were taken from the stream
    second_first = (ranked[1], ranked[0], ranked[2])  # the air grasp first: every grasp is executed, reordered
    reordered = checked(second_first, shape, gripper, PICK_SIM, 4, np.random.default_rng(0))
    assert [g.score for g in reordered][:2] in ([0.9, 0.7], [0.7, 0.9]) and reordered[2].score == 0.8
    held = {g.score: g.held for g in reordered}  # every grasp executed; the last only until its place is settled
    assert held[0.8] == (0, 4) and held[0.9][1] == 4 and 1 <= held[0.7][1] <= 4


def test_the_last_grasp_checked_stops_drawing_once_its_place_is_settled_and_every_order_stays_the_same():
    import itertools

    from onepiece_dist.picks.shape_check import drawn, lazy_order, settled_against, share_of
    from onepiece_dist.plan.planner import PlannedGrasp

    pose = np.eye(4)
    ranked = tuple(PlannedGrasp(k + 1, pose, pose, 0.08, 0.0, 0.9 - 0.1 * k, 100) for k in range(3))
    draws, saved = 4, 0
    for bits in itertools.product((False, True), repeat=3 * draws):
        patterns = [bits[k * draws:(k + 1) * draws] for k in range(3)]
        full = [sum(p) / draws for p in patterns]
        taken = []

        def share(k, earlier, patterns=patterns, taken=taken):
            outcomes = iter(patterns[k])
            got = drawn(lambda outcomes=outcomes: next(outcomes), draws, settled_against(earlier, draws))
            taken.append(len(got))
            return share_of(got, draws)

        order = lazy_order(len(ranked), share)
        lazily = ranked if order is None else tuple(ranked[i] for i in order)
        expected = ranked if full[0] == 1.0 else tuple(ranked[i] for i in np.argsort(-np.array(full), kind="stable"))
        assert [g.score for g in lazily] == [g.score for g in expected], patterns
        assert taken[:-1] == [draws] * (len(taken) - 1)  # only the last grasp's draws are ever left out
        saved += draws * len(taken) - sum(taken)
    assert saved > 0


def test_later_grasps_are_checked_only_where_none_before_held_every_draw_and_stop_at_the_first_that_does():
    from onepiece_dist.picks.shape_check import _in_order, lazy_order
    from onepiece_dist.plan.planner import PlannedGrasp

    def asked_and_order(shares, count, later):
        asked = []

        def share(k, earlier):
            asked.append(k)
            return shares[k]

        return asked, lazy_order(count, share, later)

    assert asked_and_order([1.0, 0.5, 1.0, 1.0], 2, 2) == ([0], None)  # the first held: nothing more is asked
    asked, order = asked_and_order([0.75, 0.5, 0.0, 1.0, 1.0], 3, 2)
    assert asked == [0, 1, 2, 3] and list(order) == [3, 0, 1, 2]  # the fourth held every draw: the fifth not asked
    asked, order = asked_and_order([0.25, 0.5, 0.0, 0.75, 0.5], 3, 2)
    assert asked == [0, 1, 2, 3, 4] and list(order) == [3, 1, 4, 0, 2]  # none held: every one asked, ties in rank
    asked, order = asked_and_order([0.25, 0.5, 0.0, 0.75, 0.5], 3, 0)
    assert asked == [0, 1, 2] and list(order) == [1, 0, 2]  # without later ones: the first three alone
    pose = np.eye(4)
    ranked = tuple(PlannedGrasp(k + 1, pose, pose, 0.08, 0.0, 0.9 - 0.1 * k, 100) for k in range(6))
    moved = _in_order(ranked, np.array([3, 0, 1, 2]))  # the grasps not asked keep their rank after those asked
    assert [g.score for g in moved] == [ranked[i].score for i in (3, 0, 1, 2, 4, 5)]
    assert [g.rank for g in moved] == [1, 2, 3, 4, 5, 6]


def test_the_planner_hands_the_check_the_next_grasps_as_later_ones_and_keeps_enough_ranked():
    from onepiece_dist.plan.planner import PlannedGrasp, checked_count, checked_first
    from onepiece_dist.specs.plan import PlanSpec

    pose = np.eye(4)
    ranked = tuple(PlannedGrasp(k + 1, pose, pose, 0.08, 0.0, 0.9 - 0.1 * k, 100) for k in range(8))
    seen = []

    def check(first, proposals, gripper, later):
        seen.append((len(first), later))
        return tuple(reversed(first))

    out = checked_first(ranked, None, None, 3, check, more=2)
    assert seen == [(5, 2)] and [g.score for g in out][:5] == [ranked[i].score for i in (4, 3, 2, 1, 0)]
    assert [g.score for g in out][5:] == [g.score for g in ranked[5:]]
    assert checked_count(PlanSpec(check_more=4)) == 7 and checked_count(PlanSpec(check_first=0, check_more=4)) == 0


@pytest.mark.sim
def test_the_checked_shape_weighs_what_check_density_says_and_a_heavy_one_slips():
    from onepiece_dist.picks.shape_check import check_sim, held_shares
    from onepiece_dist.plan.scorer import GraspScorer
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PlanSpec

    gripper = GraspScorer(shipped_network(), device="cpu").gripper
    points = seen_box()
    shape, across = completed_shape(points, FLOOR), np.stack(top_down_grasps(points, np.array([0, 0, -1.0]), gripper))
    assert check_sim(PlanSpec(), PICK_SIM) == PICK_SIM  # default: the protocol's density
    heavy = check_sim(PlanSpec(check_density=20_000.0), PICK_SIM)  # the box at the simulator's 2 kg ceiling
    assert heavy.density == 20_000.0 and heavy.label_trials == PICK_SIM.label_trials
    held = held_shares(shape, across, gripper, PICK_SIM, 4, np.random.default_rng(0))
    slipped = held_shares(shape, across, gripper, heavy, 4, np.random.default_rng(0))
    assert held.max() >= 0.75 and slipped.max() == 0.0
