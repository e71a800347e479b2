"""Several objects on the pick world's table (docs/picks.md; sim.beside, picks.clutter): each next one settles
beside those there, a neighbour stands in every trial, a grasp is executed on the object it closes on, and the
planner can take the whole cloud for one object."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.frames import pose_from_axes, transform_points
from onepiece_dist.core.mesh import box_mesh, sample_surface
from onepiece_dist.specs.job import GripperSpec

pytestmark = pytest.mark.sim

SIZE = (0.04, 0.03, 0.06)
VOLUME = float(np.prod(SIZE))
GAP = 0.03


def _surface(mesh, pose: np.ndarray) -> np.ndarray:
    return transform_points(sample_surface(mesh, 3000, np.random.default_rng(0))[0], pose)


@pytest.fixture(scope="module")
def two_boxes():
    from onepiece_dist.sim.pick import PickWorld

    mesh = box_mesh(SIZE)
    world = PickWorld(GripperSpec())
    world.load_object([mesh.vertices], VOLUME, 400)
    alone = world.settle(np.random.default_rng(3), mesh.vertices)
    neighbour = world.as_neighbour(alone)
    world.load_object([mesh.vertices], VOLUME, 400)
    world.set_neighbours((neighbour,))
    second = world.settle_beside(np.random.default_rng(4), mesh.vertices, GAP)
    yield world, alone, world.beside.poses(world.client)[0], second, mesh
    world.close()


def test_the_second_object_settles_beside_the_first_apart_on_the_table(two_boxes):
    from scipy.spatial import cKDTree

    world, alone, first, second, mesh = two_boxes
    a, b = _surface(mesh, first), _surface(mesh, second)
    assert a[:, 2].min() > -2e-3 and b[:, 2].min() > -2e-3  # on the table, not in it
    assert cKDTree(a).query(b)[0].min() > GAP / 2  # apart, about the gap
    assert np.allclose(first, alone, atol=1e-4)  # the first stood where it had settled
    assert world.beside.speed(world.client) < 0.01


def _side_grasp(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Approaching the second box horizontally from the first one's side, its pregrasp inside the first box."""
    way = second[:3, 3] - first[:3, 3]
    way[2] = 0.0
    way /= np.linalg.norm(way)
    closing = np.cross([0.0, 0.0, 1.0], way)
    origin = second[:3, 3] - way * (max(SIZE) / 2 + 0.01)
    return pose_from_axes(origin[None], way[None], closing[None])[0]


def test_a_neighbour_stands_in_every_trial_and_meets_a_gripper_coming_from_its_side(two_boxes):
    from onepiece_dist.sim.pick import execute_pick
    from onepiece_dist.sim.trials import LabelNoise
    from onepiece_dist.specs.plan import PICK_SIM

    world, _, first, second, _ = two_boxes
    noise, grasp = LabelNoise.from_spec(PICK_SIM), _side_grasp(first, second)
    met = execute_pick(world, grasp, second, noise, np.random.default_rng(0))
    assert (met.success, met.failure) == (False, "start_collision")
    standing = world.beside.neighbours
    world.set_neighbours(())
    try:
        alone = execute_pick(world, grasp, second, noise, np.random.default_rng(0))
    finally:
        world.set_neighbours(standing)
    assert alone.failure != "start_collision"  # the first box, not the second or the table, met the gripper
    again = execute_pick(world, grasp, second, noise, np.random.default_rng(0))
    assert again == met and len(world.beside.bodies) == 1


def test_a_world_of_one_object_picks_as_before_after_neighbours_were_removed():
    from onepiece_dist.sim.pick import PickWorld, execute_pick
    from onepiece_dist.sim.trials import LabelNoise
    from onepiece_dist.specs.plan import PICK_SIM
    from tests.test_picks import top_down

    mesh, noise = box_mesh(SIZE), LabelNoise.from_spec(PICK_SIM)
    outcomes = []
    for stood_beside in (False, True):
        world = PickWorld(GripperSpec())
        try:
            world.load_object([mesh.vertices], VOLUME, 400)
            if stood_beside:
                world.set_neighbours((world.as_neighbour(np.diag([1.0, 1.0, 1.0, 1.0]) + _shift(0.2)),))
                world.load_object([mesh.vertices], VOLUME, 400)  # a new object removes the neighbours
                assert world.beside.bodies == []
            resting = world.settle(np.random.default_rng(3), mesh.vertices)
            grasp = top_down(resting, resting[2, 3] + 0.045, 1)
            outcomes.append((execute_pick(world, grasp, resting, noise, np.random.default_rng(1)), resting))
        finally:
            world.close()
    assert outcomes[0][0] == outcomes[1][0] and np.array_equal(outcomes[0][1], outcomes[1][1])


def _shift(dx: float) -> np.ndarray:
    out = np.zeros((4, 4))
    out[0, 3] = dx
    return out


@pytest.fixture(scope="module")
def pair_spec(tmp_path_factory):
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickSpec, PlanSpec

    return PickSpec(objects="primitives[0:2]", checkpoint=str(shipped_network()), views=1, attempts=2,
                    output=str(tmp_path_factory.mktemp("clutter")), methods=("network", "random", "top_down"),
                    pictures=0, plan=PlanSpec(check_draws=1), clutter=2)


def test_a_grasp_is_executed_on_the_object_it_closes_on(pair_spec):
    from onepiece_dist.core.cloud.top_down import top_down_grasps
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clutter import SceneExecutions, groups_of, observe_scene_view, scene_object
    from onepiece_dist.picks.object_picks import process_scorer
    from onepiece_dist.sim.pick import execute_pick, pick_world
    from onepiece_dist.sim.trials import LabelNoise

    record = process_scorer(pair_spec).record
    group = groups_of(resolve_source(pair_spec.objects), 2)[0]
    pair = tuple(scene_object(pair_spec, record, ref) for ref in group.refs)
    world = pick_world(record.gripper)
    scene = observe_scene_view(pair_spec, record, world, pair, 0)
    assert len(scene.view.proposals.apart) == 2  # the view holds both, told apart
    executions = SceneExecutions(pair_spec, world, pair, scene, 0)
    down, noise = np.array([0.0, 0.0, -1.0]), LabelNoise.from_spec(pair_spec.sim)
    for k, pose in enumerate(scene.resting):
        on_it = top_down_grasps(transform_points(pair[k].surface, pose), down, record.gripper)[0]
        assert executions.target(on_it) == k
        outcome = executions.run("top_down", k, on_it)
        assert outcome.held >= 1 and outcome.failure != "no_contact", outcome  # both fingers on it, and it held
        assert np.array_equal(world.beside.neighbours[0].resting, scene.resting[1 - k])
        pair[1 - k].load_into(world)  # the same grasp executed on the other object closes on nothing
        wrong = execute_pick(world, on_it, scene.resting[1 - k], noise, np.random.default_rng(0))
        assert (wrong.success, wrong.failure) == (False, "no_contact")


def test_a_pair_is_picked_by_every_chooser_the_same_twice(pair_spec):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clutter import groups_of, pick_scene

    refs = groups_of(resolve_source(pair_spec.objects), 2)
    assert [tuple(r.name for r in g.refs) for g in refs] == [("box_40x30x60", "box_20x50x50"),
                                                             ("box_20x50x50", "box_40x30x60")]
    runs = [pick_scene(pair_spec, refs[0], 0) for _ in range(2)]
    assert runs[0].views == runs[1].views and runs[0].status == "ok"
    assert runs[0].name == "box_40x30x60+box_20x50x50"
    view = runs[0].views[0]
    assert set(view.attempts) == {"network", "random", "top_down"}
    assert all(1 <= len(tried) <= pair_spec.attempts for tried in view.attempts.values())


def test_the_planner_takes_the_cloud_for_one_object_where_the_spec_says_so():
    from onepiece_dist.plan import GraspScorer, Observation
    from onepiece_dist.plan.planner import Seen, propose
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_objects_apart import APART
    from tests.test_plan import _floor
    from tests.test_shape_check import seen_box

    record, eye = GraspScorer(shipped_network(), device="cpu").record, np.array([0.3, -0.3, 0.4])
    cloud = Observation(np.vstack([seen_box(), seen_box() + APART, _floor(0.0)]), eye, "two")
    apart = propose(cloud, record, PlanSpec(), np.random.default_rng(0))
    one = propose(cloud, record, PlanSpec(objects_apart=False), np.random.default_rng(0))
    assert (len(Seen.of(apart).separate()), apart.top_down) == (2, 6)
    assert len(Seen.of(one).separate()) == 1 and one.top_down <= 3  # the top of both: few kept
    assert np.array_equal(Seen.of(one).separate()[0], one.object_points)


def _clutter_result(apart: list[int], as_one: list[int]) -> dict:
    """Scenes of 2 of one set, two of them, 8 views each: the shipped planner's first picks ``apart``, the
    one-object planner's ``as_one``, the unchecked order's the same as the shipped."""
    from benchmarks.experiments.pick_clutter import COMPARED, paired

    names = ["a+b", "b+a"]

    def run(methods: dict) -> dict:
        return {"methods": {m: {"first_attempt": sum(v) / 16, "interval": [0.1, 0.9], "within_3": 1.0, "views": 16,
                                "failures": {"slipped_lifting": 16 - sum(v)}} for m, v in methods.items()},
                "per_scene": {m: dict(zip(names, v, strict=True)) for m, v in methods.items()},
                "verdict": "a random collision-free grasp picks 25% at the first attempt: the picks can separate"}
    scenes = {"sets": {"household": {"default": run({"network": apart, "random": [2, 2], "top_down": [4, 4]}),
                                     "unchecked": run({"network": apart}),
                                     "as_one": run({"network": as_one, "top_down": [0, 1]})}}}
    scenes.update({key: paired(scenes, *how) for key, how in COMPARED.items()})
    return {"command": "c", "date": "d", "machine": "m", "views": 8, "attempts": 3,
            "runs": {"default": {"methods": ["network", "random", "top_down"]}, "unchecked": {"methods": ["network"]},
                     "as_one": {"methods": ["network", "top_down"]}},
            "scenes": {"2": scenes}, "single": {"household": {"network": 0.8, "random": 0.3, "top_down": 0.7}}}


def test_the_clutter_page_says_a_part_helps_only_where_its_interval_over_scenes_lies_above_zero():
    from benchmarks.pages.pick_clutter_section import clutter_section, pooled_rate

    for as_one, verdict in (([5, 6], "it helps"), ([8, 6], "not shown to help")):
        result = _clutter_result([7, 8], as_one)
        assert result["scenes"]["2"]["network_vs_top_down"]["all scenes"]["mean"] == pytest.approx((3 + 4) / 16)
        lines = clutter_section(result)
        told_apart = next(line for line in lines if line.startswith("2 objects: the objects told apart"))
        assert told_apart.endswith(f"{verdict} (shown where the interval over all scenes lies above zero).")
        assert "order alone, paired over scenes: household +0.0 points [+0.0, +0.0]" in "\n".join(lines)
    assert pooled_rate(result["scenes"]["2"], 8, "default", "network") == {
        "rate": pytest.approx(15 / 16), "interval": [0.875, 1.0], "scenes": 2}
    table = "\n".join(lines)
    assert ("| 2 | household | top-down across the narrow axis of the whole cloud | 6% [10%, 90%] | 100% | - | 16 |"
            in table)
    assert "| 2 | household | network on the view (as shipped: objects told apart, first 3 checked) | 94%" in table
    assert "2 objects a scene, over all 2 scenes: the shipped planner picks **94%**" in table


def test_onepiece_grasp_one_object_plans_as_the_spec_that_takes_the_cloud_for_one_object(tmp_path):
    import json

    from typer.testing import CliRunner

    from onepiece_dist.api import plan_grasps
    from onepiece_dist.cli.main import app
    from onepiece_dist.specs.plan import PlanSpec
    from tests.test_objects_apart import APART
    from tests.test_plan import _floor
    from tests.test_shape_check import seen_box

    cloud = tmp_path / "two.npy"
    np.save(cloud, np.vstack([seen_box(), seen_box() + APART, _floor(0.0)]))
    planned = {}
    for flags in ((), ("--one-object",)):
        out = tmp_path / f"plan{len(flags)}"
        ran = CliRunner().invoke(app, ["grasp", str(cloud), "--viewpoint", "0.3,-0.3,0.4", "--check", "0", "--out",
                                       str(out), *flags])
        assert ran.exit_code == 0, ran.output
        planned[flags] = [g["pose"] for g in json.loads((out / "grasps.json").read_text())["grasps"]]
    one = plan_grasps(cloud, spec=PlanSpec(check_first=0, objects_apart=False), viewpoint=(0.3, -0.3, 0.4)).plan
    np.testing.assert_allclose(planned[("--one-object",)], [g.pose for g in one.grasps], atol=1e-8)  # as written
    assert not np.allclose(planned[()], planned[("--one-object",)], atol=1e-6)


def test_a_pick_spec_of_clutter_leaves_out_the_full_mesh_methods_and_refuses_them_by_name(tmp_path):
    from onepiece_dist.errors import SpecError
    from onepiece_dist.picks.runner import pick_units
    from onepiece_dist.specs.plan import CLUTTER_METHODS, METHODS, PickSpec, parse_pick_spec

    assert PickSpec(checkpoint="x", clutter=3).methods == CLUTTER_METHODS
    assert PickSpec(checkpoint="x").methods == METHODS
    with pytest.raises(SpecError, match="network_full_mesh sample one object's full mesh"):
        parse_pick_spec({"checkpoint": "x", "clutter": 2, "methods": ["network", "network_full_mesh"]}, "c.yaml")
    with pytest.raises(SpecError, match="holds 2 objects; a scene of 3 needs as many"):
        pick_units(PickSpec(checkpoint="x", objects="primitives[0:2]", clutter=3))
    assert [g.name for g in pick_units(PickSpec(checkpoint="x", objects="primitives[0:3]", clutter=2))] == [
        "box_40x30x60+box_20x50x50", "box_20x50x50+box_60x60x15", "box_60x60x15+box_40x30x60"]


def test_three_objects_settle_one_beside_the_others_on_the_table(pair_spec):
    from scipy.spatial import cKDTree

    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clutter import groups_of, observe_scene_view, scene_object
    from onepiece_dist.picks.object_picks import process_scorer
    from onepiece_dist.sim.pick import pick_world

    spec = pair_spec.model_copy(update={"objects": "primitives[0:3]", "clutter": 3})
    record = process_scorer(spec).record
    group = groups_of(resolve_source(spec.objects), 3)[0]
    objects = tuple(scene_object(spec, record, ref) for ref in group.refs)
    scene = observe_scene_view(spec, record, pick_world(record.gripper), objects, 0)
    surfaces = [transform_points(o.surface, pose) for o, pose in zip(objects, scene.resting, strict=True)]
    assert all(s[:, 2].min() > -2e-3 for s in surfaces)  # on the table, not in it
    for a in range(3):
        for b in range(a + 1, 3):
            assert cKDTree(surfaces[a]).query(surfaces[b])[0].min() > 1e-3  # none inside another
    assert len(scene.view.proposals.apart) == 3  # the view holds all three, told apart


@pytest.mark.slow
@pytest.mark.ray
def test_onepiece_pick_clutter_runs_in_process_and_on_the_embedded_ray_with_the_same_picks(tmp_path):
    import json

    from typer.testing import CliRunner

    from onepiece_dist.cli.main import app
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickSpec

    spec_file = tmp_path / "clutter.yaml"
    spec_file.write_text("methods: [network, random, top_down]\nplan: {candidates: 160, check_draws: 1}\n"
                         "pictures: 1\n")
    ran = CliRunner().invoke(app, ["pick", str(shipped_network()), "--objects", "primitives[0:3]", "--views", "1",
                                   "--attempts", "2", "--clutter", "3", "--spec", str(spec_file), "--in-process",
                                   "--out", str(tmp_path / "here"), "--json"])
    assert ran.exit_code == 0, ran.output
    here = json.loads(ran.stdout)
    assert [o["name"] for o in here["objects"]] == ["box_40x30x60+box_20x50x50+box_60x60x15",
                                                    "box_20x50x50+box_60x60x15+box_40x30x60",
                                                    "box_60x60x15+box_40x30x60+box_20x50x50"]
    assert [m["method"] for m in here["methods"]] == ["network", "random", "top_down"] and here["spec"]["clutter"] == 3
    assert (tmp_path / "here" / "pictures" / "box_40x30x60_box_20x50x50_box_60x60x15-view0.png").is_file()
    spec = PickSpec(**{**here["spec"], "output": str(tmp_path / "ray"), "pictures": 0, "workers": 2})
    on_ray = run_picks(spec)
    assert [[dict(v.attempts) for v in o.views] for o in on_ray.objects] == [
        [{m: tuple(a) for m, a in v["attempts"].items()} for v in o["views"]] for o in here["objects"]]
    assert all(o.node for o in on_ray.objects)  # ran in Ray workers


def test_the_picks_page_points_to_the_clutter_figures_and_says_they_are_not_the_targets():
    from benchmarks.pages.pick_clutter_section import clutter_pointer

    line = clutter_pointer(_clutter_result([7, 8], [5, 6]), None)[-1]
    assert "the shipped planner picks 94% of the views of 2 objects at the first attempt; there it chooses" in line
    assert "do not stand in for the targets above" in line
    cleared = {"objects": 4, "rates": {"all scenes": {"network": {"declutter": {"rate": 0.5}}}}}
    assert "clears 50% of 4 objects round by round" in clutter_pointer(None, cleared)[-1]
    assert clutter_pointer(None, None) == []
