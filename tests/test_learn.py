"""Grasp networks, the reader for external trainers, checkpoints, evaluation."""

import pickle
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import zarr
from typer.testing import CliRunner

from onepiece_dist.cli import app
from onepiece_dist.errors import StoreError
from onepiece_dist.learn import GraspDataset
from onepiece_dist.learn.train import average_precision, load_checkpoint, load_model, predict, train_model
from onepiece_dist.service.evaluate import top_ranked_success
from onepiece_dist.spec import TrainSpec

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def labelled(tmp_path_factory):
    """A dataset made by `onepiece run` (in-process) with grasps labelled on the one object."""
    folder = tmp_path_factory.mktemp("learn")
    spec = folder / "job.yaml"
    spec.write_text("grasps_per_object: 24\nsampler: {surface_points: 3000}\n"
                    "stages: [ingest, extract, dedup, assemble, label]\n"
                    "sim: {perturbations_per_patch: 3, points_per_grasp: 128}\n")
    out = folder / "ds.zarr"
    result = CliRunner().invoke(app, ["run", str(spec), "--objects", "primitives[0:4]", "--out", str(out),
                                      "--in-process"])
    assert result.exit_code == 0, result.output
    return out


def test_reader_returns_shapes_and_the_stored_labels(labelled):
    ds = GraspDataset(labelled)
    root = zarr.open_group(str(labelled), mode="r")
    item = ds[3]
    assert item["points"].shape == (128, 3) and item["code"].shape == (4, 8, 2)
    assert item["label"].item() == float(root["assembled/grasps/success"][3])
    assert item["group"].item() == int(root["assembled/grasps/patch"][3])
    assert np.array_equal(ds.labels(), root["assembled/grasps/success"][:].astype(float))
    code = np.packbits(item["code"].numpy().astype(bool).ravel(), bitorder="big")
    assert np.array_equal(code, root["assembled/grasps/code"][3])


def test_validation_split_never_splits_an_object(labelled):
    train, val = GraspDataset(labelled).split_by_group(0.3, seed=0)
    assert len(train) + len(val) == len(GraspDataset(labelled)) and len(val) > 0
    assert not set(train.groups[train.rows]) & set(val.groups[val.rows])


def test_missing_labels_give_a_clear_error(labelled):
    with pytest.raises(StoreError, match="grasps/success is missing"):
        GraspDataset(labelled, "grasps")


@pytest.mark.parametrize("model", ["voxel", "pointnet"])
def test_training_lowers_the_loss_and_checkpoints_reload_identically(labelled, tmp_path, model):
    spec = TrainSpec(model=model, epochs=6, batch_size=16, learning_rate=3e-3, patience=6)
    result = train_model(labelled, spec, tmp_path / "ckpt", seed=0)
    losses = [m["train_loss"] for m in result.metrics]
    assert losses[-1] < losses[0]
    ds = GraspDataset(labelled)
    first, second = predict(load_model(result.best_checkpoint), ds), predict(load_model(result.best_checkpoint), ds)
    assert np.array_equal(first, second) and np.all((first >= 0) & (first <= 1))
    resumed = train_model(labelled, spec.model_copy(update={"epochs": 7}), tmp_path / "ckpt", seed=0)
    assert [m["epoch"] for m in resumed.metrics] == list(range(len(resumed.metrics)))
    assert len(resumed.metrics) in (len(result.metrics), len(result.metrics) + 1)


class Exploit:
    def __reduce__(self):
        return (Path.write_text, (Path("/tmp/onepiece-pwned"), "pwned"))


def test_a_planted_malicious_checkpoint_is_refused(tmp_path):
    bad = tmp_path / "bad.pt"
    with open(bad, "wb") as handle:
        pickle.dump({"state_dict": Exploit()}, handle)
    with pytest.raises(pickle.UnpicklingError):
        load_checkpoint(bad)
    assert not Path("/tmp/onepiece-pwned").exists()


def test_torch_load_is_never_called_without_weights_only():
    calls = []
    for path in [*ROOT.glob("onepiece_dist/**/*.py"), *ROOT.glob("examples/*.py"), *ROOT.glob("benchmarks/*.py")]:
        calls += [(path, m.group(0)) for m in re.finditer(r"torch\.load\([^)]*\)", path.read_text())]
    assert calls and all("weights_only=True" in call for _, call in calls)


def test_average_precision_and_top_ranked_success():
    assert average_precision(np.array([0.9, 0.8, 0.1]), np.array([1.0, 0.0, 1.0])) == pytest.approx((1 + 2 / 3) / 2)
    scores = np.array([0.9, 0.1, 0.2, 0.8])
    labels = np.array([1.0, 0.0, 0.0, 0.0])
    top, random = top_ranked_success(scores, labels, np.array([0, 0, 1, 1]))
    assert top == 0.5 and random == 0.25


def test_external_example_trains_on_a_dataset_from_onepiece_run(labelled):
    script = ROOT / "examples" / "train_external.py"
    out = subprocess.run([sys.executable, str(script), str(labelled), "1"], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "validation accuracy" in out.stdout
    assert torch.__version__
