"""A network's own best grasps drawn again (issue 55, picks.top_draws): each view's top-ranked candidates executed
several times, each a label row whose ``picks`` is the share of its draws that picked; stores without the column
read each row's one execution."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.objects import resolve_source
from onepiece_dist.picks.top_draws import TopDraws, top_draws_object
from onepiece_dist.plan.scorer import Crops, GraspScorer
from onepiece_dist.plan.shipped import shipped_network
from onepiece_dist.specs.plan import PickLabelSpec
from onepiece_dist.store.pick_labels import LabelledObject, read_pick_labels, write_pick_labels

pytestmark = pytest.mark.sim


@pytest.mark.slow
def test_a_networks_best_grasps_are_its_ranking_each_with_the_share_of_its_draws_that_picked(tmp_path):
    from onepiece_dist.learn.pick_train import targets

    spec = PickLabelSpec(objects="primitives[0:1]", output=str(tmp_path), views=2, per_view=12,
                         plan={"candidates": 64, "top_down": True}, sim={"label_trials": 2, "success": "every_trial"})
    wanted = TopDraws(str(shipped_network()), top=3, draws=3, views=1)
    made = top_draws_object(spec, resolve_source(spec.objects)[0], 0, wanted)
    assert made.status == "ok" and 0 < made.rows <= 3 and set(made.view) == {0}
    again = made.picks * wanted.draws - made.success  # draw 0 is the row's own execution
    assert np.allclose(again, np.round(again)) and again.min() >= 0 and again.max() <= wanted.draws - 1
    assert made.picks.max() > 0  # a primitive on the table: its best grasps pick
    scorer = GraspScorer(shipped_network(), spec.gripper, device="cpu")
    points = made.points[:, : scorer.record.points_per_grasp]
    scores = scorer.score(Crops(np.zeros((made.rows, 1), np.uint8), np.full(made.rows, points.shape[1]), points,
                                made.context))
    assert np.all(np.diff(scores) <= 0)  # the planner's ranking, best first
    assert np.array_equal(top_draws_object(spec, resolve_source(spec.objects)[0], 0, wanted).picks, made.picks)

    write_pick_labels(tmp_path / "drawn.zarr", [made], {}, 1.0, 1.0)
    stored = read_pick_labels(tmp_path / "drawn.zarr")
    assert np.array_equal(stored.picks, made.picks)
    assert np.array_equal(targets(stored, np.arange(len(stored)), "draws", 2), made.picks)
    assert np.array_equal(targets(stored, np.arange(len(stored)), "every_trial", 2), made.success.astype(np.float32))


def test_a_store_written_without_draws_reads_each_rows_one_execution(tmp_path):
    import zarr

    rows = 3
    one = LabelledObject(0, "o", "ok", points=np.zeros((rows, 4, 3), np.float16), context=np.zeros((rows, 6),
                         np.float32), success=np.array([True, False, True]), held=np.ones(rows, np.int8),
                         failure=np.zeros(rows, np.int8), view=np.zeros(rows, np.int16),
                         pose=np.tile(np.eye(4), (rows, 1, 1)), space=np.zeros((rows, 0), np.float16),
                         outline=np.zeros((rows, 0, 3), np.float16))
    assert np.array_equal(one.picks, [1.0, 0.0, 1.0])
    write_pick_labels(tmp_path / "old.zarr", [one], {}, 1.0, 1.0)
    group = zarr.open_group(str(tmp_path / "old.zarr"), mode="r+")
    del group["picks"]  # as a store made before the column
    labels = read_pick_labels(tmp_path / "old.zarr")
    assert labels.picks.dtype == np.float32 and np.array_equal(labels.picks, [1.0, 0.0, 1.0])
    joined = labels.joined(labels)
    assert np.array_equal(joined.picks, [1.0, 0.0, 1.0] * 2) and np.array_equal(joined.object, [0, 0, 0, 1, 1, 1])
    assert np.array_equal(joined.subset(np.array([1, 5])).picks, [0.0, 1.0])
