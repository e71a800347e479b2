"""A depth camera's flying pixels dropped from its depth image (core.cloud.flying, PlanSpec.drop_flying): the
pixels an edge mixed go, a face seen grazing and a thin rim stay, and `onepiece grasp` drops them from a depth
image and refuses the option on a cloud."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.core.cloud.flying import flying_mask, without_flying


def test_the_pixels_mixed_across_an_edge_are_flagged_and_a_grazing_face_and_a_thin_rim_are_not():
    depth = np.full((40, 40), 0.60)  # the table behind
    depth[10:30, 10:20] = 0.50  # a box's face, head on
    depth[10:30, 20:30] = 0.50 + 0.004 * np.arange(10)  # its side seen grazing: 4 mm further each pixel
    depth[5, 5:35] = 0.45  # a rim one pixel thin, nearer than both its sides
    depth[34:36, 5:35] = 0.45  # and one two pixels thin
    mixed = depth.copy()
    mixed[12:28, 9] = np.linspace(0.52, 0.58, 16)  # the box's left edge mixed with the table behind it
    mixed[12:28, 30] = 0.57
    mask = flying_mask(mixed)
    assert mask[12:28, 9].all() and mask[12:28, 30].all()
    assert mask.sum() == 32  # nothing else: not the grazing side, not the rims, not the face
    assert not flying_mask(depth).any()


def test_a_pixel_without_a_return_near_it_is_never_flagged_and_zero_keeps_every_pixel():
    depth = np.full((20, 20), 0.60)
    depth[5:15, 5:10] = 0.50
    depth[5:15, 10] = 0.55  # between the face and the table
    holes = depth.copy()
    holes[5:15, 12] = np.nan  # no return two pixels on
    assert flying_mask(depth)[5:15, 10].all() and not flying_mask(holes)[5:15, 10].any()
    assert without_flying(depth, 0.0) is depth
    assert np.count_nonzero(without_flying(depth, 0.005) == 0) == 10


@pytest.mark.sim
def test_a_scenes_flying_pixels_are_dropped_from_its_depth_png_its_command_says_so_and_a_clean_view_stays(tmp_path):
    from scipy.spatial import cKDTree

    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.plan.robot import read_observation
    from onepiece_dist.specs.plan import CameraSpec

    commands = {name: write_scene("primitives[3:4]", tmp_path / name, seed=1, camera=camera).grasp_command()
                for name, camera in (("clean", CameraSpec()), ("flying", CameraSpec(flying_pixels=1.0)))}
    assert commands["flying"].endswith(" --drop-flying 0.005") and "--drop-flying" not in commands["clean"]

    def points(name: str, drop: float) -> np.ndarray:
        folder = tmp_path / name
        return read_observation(folder / "depth.png", str(folder / "intrinsics.json"), drop_flying=drop)[0].points

    clean = cKDTree(points("clean", 0.0))
    kept, dropped = points("flying", 0.0), points("flying", 0.005)
    off = lambda cloud: int(np.sum(clean.query(cloud)[0] > 0.003))  # noqa: E731 - standing off every clean point
    assert off(kept) > 100 and off(dropped) < 0.3 * off(kept)
    assert len(points("clean", 0.005)) > 0.99 * clean.n


def test_grasp_refuses_drop_flying_on_a_point_cloud_naming_intrinsics(tmp_path):
    rng = np.random.default_rng(0)
    np.save(tmp_path / "cloud.npy", rng.uniform(-0.05, 0.05, (500, 3)))
    result = CliRunner().invoke(app, ["grasp", str(tmp_path / "cloud.npy"), "--drop-flying", "0.005", "--out",
                                      str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "no pixel neighbours" in result.output and "--intrinsics" in result.output


@pytest.mark.sim
def test_a_run_from_a_first_view_judges_the_views_a_longer_run_judges_there_and_the_plan_drops_flying_pixels(tmp_path):
    from onepiece_dist.objects import resolve_source
    from onepiece_dist.picks.object_picks import pick_object
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.plan import PickSpec

    spec = PickSpec(objects="primitives[0:1]", checkpoint=str(shipped_network()), output=str(tmp_path), views=2,
                    attempts=1, pictures=0, methods=("network", "top_down"), plan={"candidates": 48, "check_first": 0},
                    sim={"label_trials": 2, "success": "every_trial"}, camera={"flying_pixels": 1.0})
    ref = resolve_source(spec.objects)[0]
    both = pick_object(spec, ref, 0)
    later = pick_object(spec.model_copy(update={"views": 1, "first_view": 1}), ref, 0)
    assert [v.view for v in both.views] == [0, 1] and later.views == both.views[1:]
    dropped = pick_object(spec.model_copy(update={"plan": spec.plan.model_copy(update={"drop_flying": 0.005})}),
                          ref, 0)
    for kept, less in zip(both.views, dropped.views, strict=True):
        assert (less.distance, less.elevation_deg) == (kept.distance, kept.elevation_deg)  # the same camera
        assert 0.95 * kept.points < less.points < kept.points  # its flying pixels gone, no more
