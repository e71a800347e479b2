"""A network that picks (issue 55): the top-down baseline, the oracle over a view's candidates, failure reasons,
each grasp's context (gravity and the object's centre in the gripper frame), labels made by executing a view's
candidates on the table, and a network fitted on them that the planner loads."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from onepiece_dist.core.cloud.swept_space import space_size
from onepiece_dist.core.cloud.top_down import top_down_grasps
from onepiece_dist.core.grasp_context import grasp_context, object_centre
from onepiece_dist.core.mesh import box_mesh
from onepiece_dist.core.voxel import crop_regions
from onepiece_dist.errors import CloudRejected
from onepiece_dist.picks.object_picks import ObjectPicks, ViewPicks, pick_object
from onepiece_dist.picks.runner import first_failures
from onepiece_dist.plan.scorer import GraspScorer
from onepiece_dist.specs.job import GripperSpec
from onepiece_dist.specs.plan import PickLabelSpec, PickSpec
from tests.test_picks import box_on_table  # noqa: F401 (a fixture)
from tests.test_plan import save_checkpoint

pytestmark = pytest.mark.sim


def test_the_context_says_where_down_is_and_where_the_object_lies_in_the_gripper_frame():
    from onepiece_dist.core.frames import pose_from_axes

    above = pose_from_axes(np.array([[0.0, 0, 0.2]]), np.array([[0, 0, -1.0]]), np.array([[1.0, 0, 0]]))
    side = pose_from_axes(np.array([[-0.2, 0, 0.0]]), np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    context = grasp_context(np.concatenate([above, side]), np.zeros(3), np.array([0, 0, -1.0]), 0.04)
    assert np.allclose(context[0, :3], [1, 0, 0])  # from above: gravity along the approach
    assert abs(context[1, 0]) < 1e-6 and np.isclose(abs(context[1, 2]), 1)  # from the side: across it
    assert np.allclose(context[0, 3:], [0.2 - 0.02, 0, 0], atol=1e-6)  # the centre lies ahead, beyond the bite
    assert np.allclose(object_centre(np.array([[0, 0, 0], [1.0, 2, 4], [0.5, 0.5, 0.5]])), [0.5, 1, 2])
    seen = grasp_context(np.concatenate([above, side]), np.zeros(3), np.array([0, 0, -1.0]), 0.04,
                         eye=np.array([0.0, 0, 1.0]))  # a camera straight above the object
    assert seen.shape == (2, 9) and np.array_equal(seen[:, :6], context)
    assert np.allclose(seen[0, 6:], [-1, 0, 0], atol=1e-6)  # from above: the camera behind the palm
    up_and_ahead = np.array([0.18, 0, 1.0]) / np.hypot(0.18, 1.0)  # a side grasp: the camera above, a little ahead
    assert np.allclose(np.abs(seen[1, 6:]), up_and_ahead, atol=1e-6) and seen[1, 6] > 0


def test_a_half_turn_about_the_approach_turns_every_context_vector_and_the_outline_with_the_crop():
    from onepiece_dist.learn.pick_train import HALF_TURN
    from onepiece_dist.learn.pick_train import _batch as training_batch
    from onepiece_dist.store.pick_labels import PickLabels

    rng = np.random.default_rng(3)
    rows = 4
    labels = PickLabels(points=rng.normal(size=(rows, 8, 3)).astype(np.float16), context=rng.normal(
        size=(rows, 9)).astype(np.float32), space=np.zeros((rows, 0), np.float16),
        outline=rng.normal(size=(rows, 5, 3)).astype(np.float16), success=np.ones(rows, bool),
        held=np.ones(rows, np.int8), failure=np.zeros(rows, np.int8), view=np.zeros(rows, np.int16),
        pose=np.tile(np.eye(4), (rows, 1, 1)), picks=np.ones(rows, np.float32), object=np.zeros(rows, np.int32),
        attrs={})
    turn = np.array([True, False, True, False])
    batch = training_batch(labels, np.arange(rows), turn)
    flips = np.tile(HALF_TURN, 3)
    assert np.array_equal(batch["context"].numpy()[turn], labels.context[turn] * flips)
    assert np.array_equal(batch["context"].numpy()[~turn], labels.context[~turn])
    assert np.array_equal(batch["points"].numpy()[turn], labels.points[turn].astype(np.float32) * HALF_TURN)
    assert np.array_equal(batch["outline"].numpy()[turn], labels.outline[turn].astype(np.float32) * HALF_TURN)
    assert np.array_equal(batch["outline"].numpy()[~turn], labels.outline[~turn].astype(np.float32))


def test_the_top_down_baseline_picks_a_box_on_the_table(box_on_table):  # noqa: F811
    from onepiece_dist.sim.pick import execute_pick

    world, resting, noise = box_on_table
    mesh = box_mesh((0.04, 0.03, 0.06))
    surface = (resting[:3, :3] @ mesh.vertices.T).T + resting[:3, 3]
    top = surface[surface[:, 2] > surface[:, 2].max() - 1e-4]
    poses = top_down_grasps(np.concatenate([surface, top]), np.array([0, 0, -1.0]), world.spec)
    assert len(poses) == 3 and np.allclose(poses[:, :3, 0], [0, 0, -1])  # straight down
    widths = [np.ptp(surface @ poses[k, :3, 1]) for k in range(2)]
    assert widths[0] < widths[1]  # the first closes across the narrow axis
    picked = execute_pick(world, poses[0], resting, noise, np.random.default_rng(0))
    assert picked.success, picked.failure


def _view(attempts, failures, pool=(0, 0)) -> ViewPicks:
    return ViewPicks(0, 0.6, 45.0, 1000, 50, attempts, failures, *pool)


def test_first_failures_are_counted_by_reason():
    views = (_view({"network": (False, True)}, {"network": ("slipped_lifting", "")}),
             _view({"network": (False,)}, {"network": ("start_collision",)}),
             _view({"network": ()}, {"network": ()}),
             _view({"network": (True,)}, {"network": ("",)}))
    counts = first_failures([ObjectPicks(0, "a", "ok", views)], "network")
    assert counts == {"no_grasp": 1, "slipped_lifting": 1, "start_collision": 1}


@pytest.mark.slow
def test_the_oracle_is_at_least_every_chooser_on_the_same_views(tmp_path):
    from onepiece_dist.objects import resolve_source

    checkpoint = save_checkpoint(tmp_path / "net.pt")
    spec = PickSpec(objects="primitives[0:1]", checkpoint=str(checkpoint), output=str(tmp_path), views=2,
                    attempts=2, pictures=0, mesh_candidates=40, plan={"candidates": 96},
                    sim={"label_trials": 2, "success": "every_trial"})
    picks = pick_object(spec, resolve_source(spec.objects)[0], 0)
    assert picks.status == "ok"
    for view in picks.views:
        assert view.pool_executed == view.candidates > 0
        for method in ("network", "random", "analytic"):
            assert view.within("oracle", 2) >= view.within(method, 2)
            assert view.first("oracle") >= view.first(method)
        assert view.first("oracle") == (view.pool_picked > 0)
        assert set(view.failures["top_down"]) <= {"", "start_collision", "no_contact", "slipped_lifting",
                                                  "dropped_shaking"}


@pytest.fixture(scope="module")
def pick_labels(tmp_path_factory):
    from onepiece_dist.picks.pick_labels import run_pick_labels
    from onepiece_dist.store.pick_labels import read_pick_labels

    folder = tmp_path_factory.mktemp("labels")
    spec = PickLabelSpec(objects="primitives[0:3]", output=str(folder), views=2, per_view=12,
                         plan={"candidates": 96}, sim={"label_trials": 2, "success": "every_trial"})
    return spec, read_pick_labels(run_pick_labels(spec, in_process=True))


@pytest.mark.slow
def test_a_planned_crop_and_context_are_the_stored_labels_of_the_same_pose_and_view(pick_labels):
    """The planner's crop of the view's cloud at a stored pose holds every stored point, and its context, the
    hand's swept space and the object's outline are the stored ones; the outlines cut again for labels made
    before they were kept are the stored ones too."""
    from dataclasses import replace

    from onepiece_dist.objects import load_object, resolve_source
    from onepiece_dist.picks.pick_labels import crop_record, outlines_again
    from onepiece_dist.picks.views import index_of, observe_view
    from onepiece_dist.plan.planner import with_space
    from onepiece_dist.sim.collision import load_simulated
    from onepiece_dist.sim.pick import PickWorld

    spec, labels = pick_labels
    assert len(labels) > 0 and labels.attrs["objects"][0]["status"] == "ok"
    ref = resolve_source(spec.objects)[0]
    loaded = load_object(ref, spec.object_job())
    world = PickWorld(spec.gripper)
    try:
        load_simulated(world, loaded, Path(spec.output) / "collision", spec.sim.collision, spec.sim.density)
        seen = observe_view(spec, crop_record(spec), world, loaded.mesh, 1)
        outlined = observe_view(spec, replace(crop_record(spec), model="pointnet_context_outline"), world,
                                loaded.mesh, 1).proposals
    finally:
        world.close()
    rows = np.flatnonzero((labels.object == 0) & (labels.view == 1))
    assert len(rows) > 0
    poses = labels.pose[rows]
    planned_outline = outlined.crops.outline[[index_of(outlined.poses, pose) for pose in poses]]
    assert np.array_equal(planned_outline.astype(np.float16), labels.outline[rows])
    assert labels.outline.shape[1:] == (64, 3) and np.abs(labels.outline[rows]).max() > 0.01
    mine = labels.object == 0
    again, same = outlines_again(spec, ref, labels.view[mine], labels.pose[mine], labels.context[mine])
    assert same.all() and np.array_equal(again, labels.outline[mine])
    moved = labels.context[mine].copy()
    moved[labels.view[mine] == 1] += 1e-3  # as a view that settled elsewhere when seen again
    _, same = outlines_again(spec, ref, labels.view[mine], labels.pose[mine], moved)
    assert np.array_equal(same, labels.view[mine] != 1)
    objects = seen.proposals.object_points
    down = -seen.proposals.plane.normal
    assert np.array_equal(grasp_context(poses, object_centre(objects), down, spec.gripper.closing_depth),
                          labels.context[rows])
    planned_space = with_space(seen.proposals.crops, poses, seen.cloud, seen.eye, spec.gripper).space
    assert np.array_equal(planned_space.astype(np.float16), labels.space[rows])
    assert labels.space.shape[1] == space_size() and (labels.space[rows] > -1).any()
    record = crop_record(spec)
    _, counts, inside = crop_regions(objects, poses, record.grid_shape(), spec.voxel.resolution, keep_points=True)
    for k, row in enumerate(rows):
        stored = labels.points[row].astype(np.float64)
        planned = np.asarray(inside[k], np.float64).astype(np.float16).astype(np.float64)
        assert counts[k] >= spec.plan.min_points
        nearest = np.abs(stored[:, None, :] - planned[None]).max(axis=2).min(axis=1)
        assert nearest.max() == 0.0  # every stored point is one of the planner's crop of that pose


@pytest.mark.slow
def test_a_network_fitted_on_pick_labels_loads_safely_and_needs_the_context(pick_labels, tmp_path):
    from dataclasses import replace

    from onepiece_dist.learn.pick_train import PickTrainOptions, train_on_pick_labels
    from onepiece_dist.plan.scorer import Crops

    spec, labels = pick_labels
    assert set(np.unique(labels.failure)) <= set(range(5)) and labels.success.any() and not labels.success.all()
    crop = {"gripper": spec.gripper.model_dump(mode="json"), "voxel": spec.voxel.model_dump(mode="json"),
            "points_per_grasp": spec.points_per_grasp}
    result = train_on_pick_labels(labels, tmp_path, crop, PickTrainOptions(epochs=2, validation=0.34))
    assert len(result.epochs) == 2 and result.checkpoint.is_file()
    ranked = train_on_pick_labels(labels, tmp_path / "listwise", crop,
                                  PickTrainOptions(epochs=1, validation=0.34, ranking=1.0))
    assert len(ranked.epochs) == 1 and np.isfinite(ranked.epochs[0].train_loss)
    cosine = train_on_pick_labels(labels, tmp_path / "cosine", crop,
                                  PickTrainOptions(epochs=3, patience=0, validation=0.34, schedule="cosine"))
    assert len(cosine.epochs) == 3  # never stopped early: the rate decays over every epoch
    torch.load(result.checkpoint, weights_only=True)
    scorer = GraspScorer(result.checkpoint, GripperSpec(), device="cpu")
    n = 5
    with_context = Crops(np.zeros((n, 1), np.uint8), np.full(n, 300), labels.points[:n], labels.context[:n])
    scores = scorer.score(with_context)
    assert scores.shape == (n,) and np.all((scores >= 0) & (scores <= 1))
    with pytest.raises(CloudRejected, match="context"):
        scorer.score(Crops(with_context.codes, with_context.counts, with_context.points))
    spaced = train_on_pick_labels(labels, tmp_path / "space", crop,
                                  PickTrainOptions(model="pointnet_context_space", epochs=1, validation=0.34))
    space_scorer = GraspScorer(spaced.checkpoint, GripperSpec(), device="cpu")
    full = Crops(with_context.codes, with_context.counts, with_context.points, with_context.context,
                 labels.space[:n].astype(np.float32))
    assert space_scorer.score(full).shape == (n,)
    with pytest.raises(CloudRejected, match="swept space"):
        space_scorer.score(with_context)
    outlined = train_on_pick_labels(labels, tmp_path / "outline", crop,
                                    PickTrainOptions(model="pointnet_context_outline", epochs=1, validation=0.34))
    outline_scorer = GraspScorer(outlined.checkpoint, GripperSpec(), device="cpu")
    assert outline_scorer.score(replace(with_context, outline=labels.outline[:n].astype(np.float32))).shape == (n,)
    still = train_on_pick_labels(labels, tmp_path / "still", crop, PickTrainOptions(
        epochs=1, validation=0.34, learning_rate=0.0, start_from=str(result.checkpoint)))
    before, after = (torch.load(c, weights_only=True)["state_dict"] for c in (result.checkpoint, still.checkpoint))
    weights = [k for k in before if k.endswith("weight")]
    assert weights and all(torch.equal(before[k], after[k]) for k in weights)  # it starts from those weights
    with pytest.raises(ValueError, match="cannot start from it"):
        train_on_pick_labels(labels, tmp_path / "other", crop, PickTrainOptions(
            model="pointnet_context_outline", epochs=1, validation=0.34, start_from=str(result.checkpoint)))
    with pytest.raises(CloudRejected, match="outline"):
        outline_scorer.score(with_context)
    on_policy(spec, labels, result.checkpoint)


def on_policy(spec: PickLabelSpec, labels, checkpoint: Path) -> None:
    """With a checkpoint, a view's labelled candidates are the network's best-scored first, the rest at random."""
    from onepiece_dist.picks.pick_labels import _chosen
    from onepiece_dist.plan.scorer import Crops

    n = 20
    crops = Crops(np.zeros((n, 1), np.uint8), np.full(n, 300), labels.points[:n], labels.context[:n],
                  labels.space[:n].astype(np.float32))
    scores = GraspScorer(checkpoint, GripperSpec(), device="cpu").score(
        Crops(crops.codes, crops.counts, crops.points[:, :128], crops.context))
    asked = spec.model_copy(update={"checkpoint": str(checkpoint), "per_view": 8, "top_share": 0.5})
    proposals = SimpleNamespace(crops=crops, top_down=0)
    chosen = _chosen(asked, proposals, np.random.default_rng(0))
    assert len(chosen) == 8 and len(set(chosen)) == 8 and np.all(np.diff(chosen) > 0)
    assert set(np.argsort(-scores, kind="stable")[:4]) <= set(chosen)
    again = _chosen(asked, proposals, np.random.default_rng(1))
    assert set(again) != set(chosen)  # the other half is drawn at random
    top_down = _chosen(spec.model_copy(update={"per_view": 8}), SimpleNamespace(crops=crops, top_down=3),
                       np.random.default_rng(0))
    assert len(top_down) == 8 and {17, 18, 19} <= set(top_down)  # the top-down grasps, always, in place of three
    scored = _chosen(asked, SimpleNamespace(crops=crops, top_down=3), np.random.default_rng(0))
    assert np.array_equal(scored, chosen)  # with a checkpoint the top-down grasps are scored as any other


def test_the_cosine_schedule_decays_the_rate_from_its_start_towards_zero():
    from onepiece_dist.learn.pick_train import PickTrainOptions, learning_rate

    cosine = PickTrainOptions(epochs=10, learning_rate=1e-3, schedule="cosine")
    rates = [learning_rate(cosine, e) for e in range(10)]
    assert rates[0] == pytest.approx(1e-3) and rates[5] == pytest.approx(5e-4) and 0 < rates[-1] < 5e-5
    assert np.all(np.diff(rates) < 0)
    assert {learning_rate(PickTrainOptions(), e) for e in range(10)} == {1e-3}
    with pytest.raises(ValueError, match="schedule 'step'"):
        learning_rate(PickTrainOptions(schedule="step"), 0)


def test_the_listwise_term_is_small_only_where_each_views_successes_score_above_its_failures():
    from onepiece_dist.learn.pick_train import listwise_loss

    target = torch.tensor([1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0])
    keys = np.array([7, 7, 7, 8, 8, 9, 9])  # view 8 all successes, view 9 all failures: nothing to rank there
    right = listwise_loss(torch.tensor([4.0, -4.0, -4.0, 0.0, 0.0, 0.0, 0.0]), target, keys)
    wrong = listwise_loss(torch.tensor([-4.0, 4.0, 4.0, 0.0, 0.0, 0.0, 0.0]), target, keys)
    assert 0 < right.item() < 0.01 and wrong.item() > 8
    assert listwise_loss(torch.zeros(7), target, keys).item() == pytest.approx(np.log(3))  # view 7 alone: 1 of 3
    logits = torch.zeros(4, requires_grad=True)
    listwise_loss(logits, torch.tensor([0.0, 0.0, 1.0, 1.0]), np.array([5, 5, 6, 6])).backward()
    assert torch.count_nonzero(logits.grad) == 0  # no view with both outcomes: no push


def test_listwise_batches_hold_each_views_rows_together_in_a_seeded_order(pick_labels):
    from onepiece_dist.learn.pick_train import _view_order, view_keys

    _, labels = pick_labels
    rows = np.arange(len(labels))
    order = _view_order(labels, rows, np.random.default_rng(3))
    assert sorted(order) == list(rows)
    keys = view_keys(labels, order)
    runs = np.flatnonzero(np.diff(keys)) + 1
    assert len(runs) + 1 == len(np.unique(keys))  # each view's rows in one run
    assert np.array_equal(order, _view_order(labels, rows, np.random.default_rng(3)))


def test_the_default_jobs_verdict_says_whether_the_network_is_above_a_guess_with_an_interval():
    from onepiece_dist.job.stages.evaluate import against_a_guess

    rng = np.random.default_rng(0)
    random = rng.uniform(0.2, 0.4, 16)
    above, said = against_a_guess(np.ones(16), random)
    assert above[0] > 0 and said == "the network is above a guess"
    tied, said = against_a_guess(rng.integers(0, 2, 16).astype(float), np.full(16, 0.5))
    assert tied[0] < 0 < tied[1] and "cannot tell" in said
    below, said = against_a_guess(np.zeros(16), random)
    assert below[1] < 0 and said == "the network is below a guess"


def test_a_study_reports_a_tie_by_picks_as_a_tie():
    """Issue 58: equal pick rates are a tie, never a win (an interval test, not >=)."""
    from onepiece_dist.study.picks import compare
    from onepiece_dist.study.spec import StudySpec

    spec = StudySpec(train="primitives[0:2]", heldout="primitives[2:4]")
    same = np.array([0.5, 0.25, 0.75, 0.5, 1.0, 0.0, 0.5, 0.25])
    assert compare(same, same.copy(), spec) == "ties"
    assert compare(same + 0.2, same, spec) == "beats" and compare(same, same + 0.2, spec) == "loses"
    noisy = np.random.default_rng(1).permutation(same)
    assert compare(noisy, same, spec) == "ties"


def test_the_franka_hand_collides_where_the_box_palm_does_not():
    """The panda preset: the hand's collision mesh (20 cm across the closing axis) in physics and in the planner's
    collision test; a point 8 cm to the side of the palm meets the Franka hand, not a box palm of the same sizes."""
    import pybullet_data
    import trimesh

    from onepiece_dist.core.frames import pose_from_axes
    from onepiece_dist.core.sampling import FRANKA_HAND_BOUNDS, collides
    from onepiece_dist.gripper.presets import PRESETS
    from onepiece_dist.sim.trials import place, starts_in_collision
    from onepiece_dist.sim.world import SimWorld

    hand = trimesh.load(Path(pybullet_data.getDataPath()) / "franka_panda/meshes/collision/hand.obj", force="mesh")
    assert np.allclose(hand.bounds, FRANKA_HAND_BOUNDS, atol=1e-3)
    franka = GripperSpec(**PRESETS["panda"])
    boxed = franka.model_copy(update={"name": "panda_box_palm"})
    pose = pose_from_axes(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    beside = np.array([[-0.03, 0.08, 0.0]])  # behind the palm face, 8 cm along the closing axis
    assert collides(beside, pose, franka)[0] and not collides(beside, pose, boxed)[0]
    block = box_mesh((0.02, 0.02, 0.02))
    hits = []
    for gripper in (franka, boxed):
        world = SimWorld(gripper)
        try:
            world.load_object([block.vertices + beside[0]], 0.02**3, 400)
            place(world, pose[0])
            hits.append(starts_in_collision(world))
        finally:
            world.close()
    assert hits == [True, False]


def test_a_label_store_written_before_the_top_down_field_reads_as_having_executed_none():
    written = PickLabelSpec(plan={"top_down": False}).model_dump(mode="json")
    del written["plan"]["top_down"]  # as the stores made before plan.top_down existed keep it
    assert PickLabelSpec.stored(written).plan.top_down is False
    assert PickLabelSpec.model_validate(written).plan.top_down is True  # today's default would misread it
    today = PickLabelSpec().model_dump(mode="json")
    assert PickLabelSpec.stored(today) == PickLabelSpec()  # a store that says so keeps what it says


def test_a_label_store_written_before_the_table_clearance_field_reads_as_made_2_mm_over_the_table(tmp_path):
    written = PickLabelSpec(output=str(tmp_path)).model_dump(mode="json")
    del written["plan"]["table_clearance"]  # as the stores made before plan.table_clearance existed keep it
    stored = PickLabelSpec.stored(written)
    assert stored.plan.table_clearance == 0.002 != PickLabelSpec().plan.table_clearance
    assert stored != PickLabelSpec(output=str(tmp_path))  # today's spec is not the one those labels were made by
    assert PickLabelSpec.stored(PickLabelSpec(output=str(tmp_path)).model_dump(mode="json")).plan.table_clearance \
        == PickLabelSpec().plan.table_clearance


def test_labels_made_2_mm_over_the_table_are_kept_and_never_taken_for_todays(tmp_path):
    from onepiece_dist.errors import SpecError
    from onepiece_dist.picks.pick_labels import labels_made
    from onepiece_dist.store.pick_labels import LabelledObject, write_pick_labels

    rows = 2
    made = LabelledObject(0, "box", "ok", points=np.zeros((rows, 8, 3), np.float16),
                          context=np.zeros((rows, 6), np.float32), space=np.zeros((rows, 0), np.float16),
                          outline=np.zeros((rows, 4, 3), np.float16), success=np.ones(rows, bool),
                          held=np.ones(rows, np.int8), failure=np.zeros(rows, np.int8),
                          view=np.zeros(rows, np.int16), pose=np.tile(np.eye(4), (rows, 1, 1)))
    today = PickLabelSpec(output=str(tmp_path))
    written = today.model_dump(mode="json")
    del written["plan"]["table_clearance"]
    write_pick_labels(tmp_path / "pick_labels.zarr", [made], written, 1.0, 1.0)
    with pytest.raises(SpecError, match="table_clearance|plan"):
        labels_made(today)
    then = today.model_copy(update={"plan": today.plan.model_copy(update={"table_clearance": 0.002})})
    assert labels_made(then) == tmp_path / "pick_labels.zarr"
