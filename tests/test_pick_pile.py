"""Objects piled on the table (`onepiece pick --clutter N --pile`, `onepiece scene --pile`; sim.pick.settle_onto):
each next object dropped onto those there instead of beside them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from onepiece_dist.core.frames import transform_points

pytestmark = pytest.mark.sim


def _lowest(objects, resting) -> list[float]:
    return [float(transform_points(o.mesh.vertices, p)[:, 2].min()) for o, p in zip(objects, resting, strict=True)]


def test_a_plate_dropped_onto_a_plate_rests_on_it_where_beside_it_rests_on_the_table(tmp_path):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clutter import loaded_object, settle_scene
    from onepiece_dist.sim.pick import PickWorld
    from onepiece_dist.specs.job import GripperSpec, JobSpec

    plates = tuple(loaded_object(ref, JobSpec(), Path(tmp_path)) for ref in resolve_source("primitives[2:3]") * 2)
    world = PickWorld(GripperSpec())  # box_60x60x15: 15 mm tall
    piled = [_lowest(plates, settle_scene(world, plates, np.random.default_rng(seed), pile=True)) for seed in range(4)]
    apart = [_lowest(plates, settle_scene(world, plates, np.random.default_rng(seed))) for seed in range(4)]
    world.close()
    assert all(first < 0.003 for first, _ in piled + apart)  # the first on the table either way
    assert sum(second > 0.014 for _, second in piled) >= 3  # on the first plate (one may slide off its edge)
    assert all(second < 0.003 for _, second in apart)


def test_a_pile_needs_two_objects_or_more_and_the_scene_files_say_it_was_piled(tmp_path):
    import json

    from onepiece_dist.objects import load_object, resolve_source
    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.specs.job import JobSpec
    from onepiece_dist.specs.plan import PickSpec

    with pytest.raises(ValueError, match="pile drops each next object onto those there: it needs clutter 2"):
        PickSpec(checkpoint="net.pt", pile=True)
    assert PickSpec(checkpoint="net.pt", clutter=2, pile=True).pile
    write_scene("primitives[2:3]+primitives[2:3]", tmp_path, count=2, pile=True)
    scene = json.loads((tmp_path / "scene.json").read_text())
    assert scene["pile"] is True
    plate = load_object(resolve_source("primitives[2:3]")[0], JobSpec()).mesh.vertices
    lowest = [transform_points(plate, np.array(o["resting_pose"]))[:, 2].min() for o in scene["objects"]]
    assert lowest[0] < 0.003 and lowest[1] > 0.014  # the second on the first


def test_the_pile_section_says_the_objects_were_piled_and_the_beside_section_does_not():
    from benchmarks.pages.pick_clutter_section import clutter_section
    from tests.test_pick_clutter import _clutter_result

    beside, piled = _clutter_result([7, 8], [5, 6]), {**_clutter_result([7, 8], [5, 6]), "pile": True}
    assert clutter_section(beside)[0].startswith("## Several objects on the table: ")
    assert clutter_section(piled)[0].startswith("## Objects piled on the table: ")
    assert "--clutter N --pile` (`PickSpec.pile`) piles N on it" in clutter_section(piled)[2]
    assert "onto those already there" in clutter_section(piled)[2]
    words = clutter_section(beside)[2]
    assert "onto" not in words and "1-5 cm beyond those already there" in words


def test_in_a_pile_what_leaned_on_a_picked_object_falls_and_what_leaves_the_table_leaves_the_scene(tmp_path):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clearance import resettled
    from onepiece_dist.picks.clutter import loaded_object, settle_scene
    from onepiece_dist.sim.pick import PickWorld, on_table
    from onepiece_dist.specs.job import GripperSpec, JobSpec

    plates = tuple(loaded_object(ref, JobSpec(), Path(tmp_path)) for ref in resolve_source("primitives[2:3]") * 2)
    world = PickWorld(GripperSpec())
    resting = list(settle_scene(world, plates, np.random.default_rng(0), pile=True))
    assert _lowest(plates, resting)[1] > 0.014  # the second plate on the first
    kept = resettled(world, plates, resting, [0, 1])  # nothing taken: the pile stays as it stood
    assert np.allclose(kept[1][:3, 3], resting[1][:3, 3], atol=0.002)
    fallen = resettled(world, plates, resting, [1])  # the first taken away
    world.close()
    assert _lowest(plates, fallen)[1] < 0.003 and np.array_equal(fallen[0], resting[0])
    assert on_table(fallen[1])
    off = np.eye(4)
    off[:3, 3] = [0.6, 0.0, -0.2]
    assert not on_table(off)


def test_a_failed_pick_in_a_pile_leaves_the_objects_where_the_hand_left_them_and_a_start_in_collision_moves_none(
        tmp_path):
    from onepiece_dist.core.cloud.top_down import top_down_grasps
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.clutter import Scene, SceneExecutions, loaded_object, settle_scene
    from onepiece_dist.sim.pick import PickWorld
    from onepiece_dist.specs.job import GripperSpec, JobSpec
    from onepiece_dist.specs.plan import PickSpec

    plates = tuple(loaded_object(ref, JobSpec(), Path(tmp_path)) for ref in resolve_source("primitives[2:3]") * 2)
    world = PickWorld(GripperSpec())
    resting = settle_scene(world, plates, np.random.default_rng(0), pile=True)
    executions = SceneExecutions(PickSpec(checkpoint="net.pt", clutter=2, pile=True), world, plates,
                                 Scene(resting, None), 0)
    under = top_down_grasps(transform_points(plates[0].mesh.vertices, resting[0]), np.array([0.0, 0, -1]),
                            world.spec)[0]  # closes on the lower plate, the upper one lying across it
    after = executions.aftermath(under)
    sunk = under.copy()
    sunk[2, 3] -= 0.05  # the hand would start inside the table
    unmoved = executions.aftermath(sunk)
    world.close()
    assert after[0][2, 3] - resting[0][2, 3] > 0.01 and resting[1][2, 3] - after[1][2, 3] > 0.01  # pulled out: on top
    assert all(np.array_equal(a, b) for a, b in zip(unmoved, resting, strict=True))
