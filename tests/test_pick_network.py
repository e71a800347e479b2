"""A network that picks the user's objects with the user's gripper (issue 55): `onepiece pick-labels` makes pick
labels of their objects, `onepiece pick-train` fits the shipped networks' design on them and says what its
validation views say against a guess, and `onepiece grasp` plans with what it wrote."""

from __future__ import annotations

import json
import shlex

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.learn.pick_network import ValidationPicks
from onepiece_dist.store.pick_labels import PickLabels, read_pick_labels

pytestmark = pytest.mark.sim
SMALL = ["--objects", "primitives[0:3]", "--views", "2", "--per-view", "12"]


@pytest.fixture(scope="module")
def small_spec(tmp_path_factory):
    """A pick label spec small enough for a test: few candidates a view, two trials each."""
    path = tmp_path_factory.mktemp("spec") / "labels.yaml"
    path.write_text("plan: {candidates: 96}\nsim: {label_trials: 2, success: every_trial}\n")
    return path


@pytest.fixture(scope="module")
def labelled(small_spec, tmp_path_factory):
    out = tmp_path_factory.mktemp("labels")
    made = CliRunner().invoke(app, ["pick-labels", *SMALL, "--spec", str(small_spec), "--out", str(out),
                                    "--in-process"])
    assert made.exit_code == 0, made.output
    return out, made


def arrays(labels: PickLabels) -> dict[str, np.ndarray]:
    return {k: v for k, v in vars(labels).items() if isinstance(v, np.ndarray)}


@pytest.mark.slow
def test_pick_labels_are_kept_again_for_the_same_spec_and_never_replaced_by_another(labelled, small_spec):
    out, made = labelled
    path = out / "pick_labels.zarr"
    assert made.stdout.strip() == str(path) and "onepiece pick-train" in made.output
    labels = read_pick_labels(path)
    assert len(labels) > 0 and labels.success.any() and not labels.success.all()
    assert labels.attrs["spec"]["per_view"] == 12 and labels.attrs["spec"]["sim"]["label_trials"] == 2
    again = CliRunner().invoke(app, ["pick-labels", *SMALL, "--spec", str(small_spec), "--out", str(out),
                                     "--in-process"])
    assert again.exit_code == 0 and "already there: kept" in again.output
    other = CliRunner().invoke(app, ["pick-labels", *SMALL, "--spec", str(small_spec), "--out", str(out), "--seed",
                                     "1", "--in-process"])
    assert other.exit_code == 2 and str(path) in other.output and "seed" in other.output
    after = read_pick_labels(path)
    assert all(np.array_equal(a, b) for a, b in zip(arrays(labels).values(), arrays(after).values(), strict=True))
    bad = CliRunner().invoke(app, ["pick-labels", "--views", "0", "--out", str(out / "x"), "--in-process"])
    assert bad.exit_code == 2 and "views" in bad.output


@pytest.mark.slow
def test_pick_train_fits_the_same_network_twice_and_grasp_plans_with_it(labelled, tmp_path):
    out, _ = labelled
    runner = CliRunner()
    fits = [runner.invoke(app, ["pick-train", str(out / "pick_labels.zarr"), "--out", str(tmp_path / name),
                                "--epochs", "2", "--validation", "0.34"]) for name in ("a", "b")]
    assert all(f.exit_code == 0 for f in fits), fits[0].output
    checkpoint = tmp_path / "a" / "best.pt"
    assert fits[0].stdout.strip() == str(checkpoint) and "validation objects" in fits[0].output
    assert f"onepiece pick {checkpoint}" in fits[0].output
    held_out = runner.invoke(app, ["pick-train", str(out / "pick_labels.zarr"), "--out", str(tmp_path / "c"),
                                   "--validation", "0.9"])
    assert held_out.exit_code == 2 and "no object is left to train on" in held_out.output
    saved = [torch.load(tmp_path / name / "best.pt", weights_only=True) for name in ("a", "b")]
    assert saved[0]["crop"]["source"] == "pick_labels" and saved[0]["model"] == "pointnet_context"
    assert all(torch.equal(saved[0]["state_dict"][k], saved[1]["state_dict"][k]) for k in saved[0]["state_dict"])
    record = json.loads((tmp_path / "a" / "network.json").read_text())
    assert record["design"] == "context_balanced" and record["validation"]["views"] > 0
    assert "start_from" not in record
    scene = runner.invoke(app, ["scene", "primitives[3:4]", "--out", str(tmp_path / "scene")])
    assert scene.exit_code == 0, scene.output
    command = shlex.split(json.loads((tmp_path / "scene" / "scene.json").read_text())["grasp"])[1:]
    planned = runner.invoke(app, [*command, "--checkpoint", str(checkpoint), "--check", "0", "--out",
                                  str(tmp_path / "g"), "--json"])
    assert planned.exit_code == 0, planned.output
    assert json.loads(planned.stdout)["grasps"]


@pytest.mark.slow
def test_pick_train_starts_from_the_shipped_network_where_asked(labelled, tmp_path):
    from onepiece_dist.plan.shipped import NETWORK

    out, _ = labelled
    runner, labels = CliRunner(), str(out / "pick_labels.zarr")
    fits = {start: runner.invoke(app, ["pick-train", labels, "--out", str(tmp_path / start), "--epochs", "1",
                                       "--validation", "0.34", *(["--start-from", "shipped"] if start else [])])
            for start in ("", "shipped")}
    assert all(f.exit_code == 0 for f in fits.values()), fits["shipped"].output
    shipped = torch.load(NETWORK, weights_only=True)["state_dict"]

    def apart(folder: str) -> float:  # how far a fit's weights lie from the shipped network's
        fitted = torch.load(tmp_path / folder / "best.pt", weights_only=True)["state_dict"]
        return sum(float((fitted[k] - shipped[k]).norm()) for k in shipped if shipped[k].is_floating_point())

    assert apart("shipped") < apart("") / 4  # one epoch moves it a little from where it started
    record = json.loads((tmp_path / "shipped" / "network.json").read_text())
    assert record["start_from"] == str(NETWORK)
    saved = torch.load(tmp_path / "shipped" / "best.pt", weights_only=True)
    assert saved["crop"]["source"] == "pick_labels"  # the crop record of the labels' gripper, not the start's


@pytest.mark.ray
@pytest.mark.slow
def test_pick_labels_on_the_embedded_ray_are_the_in_process_labels(labelled, small_spec, tmp_path):
    out, _ = labelled
    made = CliRunner().invoke(app, ["pick-labels", *SMALL, "--spec", str(small_spec), "--out", str(tmp_path)])
    assert made.exit_code == 0, made.output
    here, there = (arrays(read_pick_labels(folder / "pick_labels.zarr")) for folder in (out, tmp_path))
    assert all(np.array_equal(here[k], there[k]) for k in here)


def test_pick_train_refuses_what_is_not_a_label_store_and_an_unknown_design(tmp_path):
    from onepiece_dist.plan.shipped import NETWORK

    runner = CliRunner()
    other_hand = runner.invoke(app, ["pick-labels", "--checkpoint", str(NETWORK), "--gripper", "panda", "--out",
                                     str(tmp_path / "o"), "--in-process"])
    assert other_hand.exit_code == 2 and "gripper" in other_hand.output
    assert not (tmp_path / "o").exists()  # refused before any work
    (tmp_path / "empty.zarr").mkdir()
    refused = runner.invoke(app, ["pick-train", str(tmp_path / "empty.zarr"), "--out", str(tmp_path / "n")])
    assert refused.exit_code == 2 and "not a pick-labels store" in refused.output
    assert str(tmp_path / "empty.zarr") in refused.output.replace("\n", "")
    unknown = runner.invoke(app, ["pick-train", str(tmp_path / "empty.zarr"), "--design", "context_balancd"])
    assert unknown.exit_code == 2 and "context_balanced" in unknown.output
    missing = runner.invoke(app, ["pick-train", str(tmp_path / "empty.zarr"), "--start-from",
                                  str(tmp_path / "none.pt")])
    assert missing.exit_code == 2 and "none.pt" in missing.output and "shipped" in missing.output
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    junk = runner.invoke(app, ["pick-train", str(tmp_path / "empty.zarr"), "--start-from", str(tmp_path / "junk.pt")])
    assert junk.exit_code == 2 and "junk.pt" in junk.output and "not a checkpoint" in junk.output
    other_model = runner.invoke(app, ["pick-train", str(tmp_path / "empty.zarr"), "--start-from", str(NETWORK),
                                      "--design", "crop_only"])
    assert other_model.exit_code == 2 and "pointnet_context" in other_model.output


def synthetic(success: np.ndarray, objects: int) -> PickLabels:
    """Labels of ``objects`` objects, 2 views each, ``success`` (rows) split evenly over the views."""
    rows = len(success)
    view_of = np.repeat(np.arange(2 * objects), rows // (2 * objects))
    empty = np.zeros((rows, 0), np.float16)
    return PickLabels(points=empty, context=empty, space=empty, outline=empty, success=success,
                      held=success.astype(np.int8), failure=np.zeros(rows, np.int8),
                      object=(view_of // 2).astype(np.int32), view=(view_of % 2).astype(np.int16),
                      pose=np.zeros((rows, 4, 4)), picks=success.astype(np.float32), attrs={})


def test_validation_views_say_above_a_guess_only_where_the_network_beats_one():
    rng = np.random.default_rng(0)
    success = rng.random(8 * 2 * 8) < 0.3  # 8 objects, 2 views of 8 candidates
    labels = synthetic(success, 8)
    rows = np.arange(len(success))
    knowing = ValidationPicks.of(labels, rows, success.astype(np.float64))
    assert knowing.top1 > knowing.guess and knowing.above_guess[0] > 0 and "above a guess" in knowing.verdict
    wrong = ValidationPicks.of(labels, rows, -success.astype(np.float64))  # a failure first wherever there is one
    assert wrong.top1 < wrong.guess and wrong.above_guess[1] < 0 and "below a guess" in wrong.verdict
    every = ValidationPicks.of(synthetic(np.ones(len(success), bool), 8), rows, np.zeros(len(success)))
    assert "cannot tell a network from a guess" in every.verdict


@pytest.mark.slow
def test_pick_labels_read_a_folder_of_centimetres_with_units_and_say_so_without(small_spec, tmp_path):
    from onepiece_dist.core.mesh import box_mesh

    mesh = box_mesh((4.0, 6.0, 10.0))  # a 4 x 6 x 10 cm box, written in centimetres
    folder = tmp_path / "meshes"
    folder.mkdir()
    lines = [f"v {x} {y} {z}" for x, y, z in mesh.vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces]
    (folder / "box.obj").write_text("\n".join(lines) + "\n")
    args = ["pick-labels", "--objects", str(folder), "--views", "1", "--per-view", "6", "--spec", str(small_spec),
            "--in-process"]
    refused = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "m")])
    assert refused.exit_code == 1 and "box.obj: rejected" in refused.output and "--units cm" in refused.output
    made = CliRunner().invoke(app, [*args, "--units", "cm", "--out", str(tmp_path / "cm")])
    assert made.exit_code == 0, made.output
    assert len(read_pick_labels(tmp_path / "cm" / "pick_labels.zarr")) > 0
    picks = ["pick", "--objects", str(folder), "--views", "1", "--attempts", "1", "--in-process"]
    nothing = CliRunner().invoke(app, [*picks, "--out", str(tmp_path / "p")])
    assert nothing.exit_code == 1 and "--units cm" in nothing.output and "nothing was picked" in nothing.output
    picked = CliRunner().invoke(app, [*picks, "--units", "cm", "--out", str(tmp_path / "q")])
    assert picked.exit_code == 0, picked.output
