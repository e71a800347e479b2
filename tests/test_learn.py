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

from onepiece_dist.cli.main import app
from onepiece_dist.errors import StoreError
from onepiece_dist.job.stages.evaluate import top_ranked_success
from onepiece_dist.learn import ChunkBatchSampler, GraspDataset
from onepiece_dist.learn.train import load_checkpoint, load_model, predict, train_model
from onepiece_dist.specs.job import TrainSpec
from onepiece_dist.stats.ranking import average_precision
from tests.factories import synthetic_labelled_dataset

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
    losses = [m.train_loss for m in result.metrics]
    assert losses[-1] < losses[0]
    ds = GraspDataset(labelled)
    first, second = predict(load_model(result.best_checkpoint), ds), predict(load_model(result.best_checkpoint), ds)
    assert np.array_equal(first, second) and np.all((first >= 0) & (first <= 1))
    resumed = train_model(labelled, spec.model_copy(update={"epochs": 7}), tmp_path / "ckpt", seed=0)
    assert [m.epoch for m in resumed.metrics] == list(range(len(resumed.metrics)))
    assert len(resumed.metrics) in (len(result.metrics), len(result.metrics) + 1)


class Exploit:
    def __reduce__(self):
        return (Path.write_text, (Path("/tmp/onepiece-pwned"), "pwned"))


def test_a_planted_malicious_checkpoint_is_refused(tmp_path, record_figure):
    bad = tmp_path / "bad.pt"
    with open(bad, "wb") as handle:
        pickle.dump({"state_dict": Exploit()}, handle)
    with pytest.raises(pickle.UnpicklingError):
        load_checkpoint(bad)
    assert not Path("/tmp/onepiece-pwned").exists()
    record_figure("malicious checkpoint refused (UnpicklingError), its payload never ran")


def test_torch_load_is_never_called_without_weights_only(record_figure):
    calls = []
    for path in [*ROOT.glob("onepiece_dist/**/*.py"), *ROOT.glob("examples/*.py"), *ROOT.glob("benchmarks/**/*.py")]:
        calls += [(path, m.group(0)) for m in re.finditer(r"torch\.load\([^)]*\)", path.read_text())]
    assert calls and all("weights_only=True" in call for _, call in calls)
    record_figure(f"{len(calls)} torch.load calls, all with weights_only=True")


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
    epochs = re.findall(r"epoch (\d+): train loss ([\d.]+), validation accuracy ([\d.]+)", out.stdout)
    assert [int(epoch) for epoch, _, _ in epochs] == [0]  # one epoch asked for, one trained
    loss, accuracy = float(epochs[0][1]), float(epochs[0][2])
    assert 0 < loss < 2 and 0 <= accuracy <= 1  # a binary cross-entropy that trained, not a NaN or a blow-up


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    # 750-point clouds: 512-row chunks, so 1,500 rows span three
    return synthetic_labelled_dataset(tmp_path_factory.mktemp("reader") / "s.zarr", rows=1500, points=750)


@pytest.mark.parametrize("memory_bytes", [0, 2**26])  # every array read per batch from the store / held in memory
def test_a_batch_read_equals_the_items_read_one_by_one(synthetic, memory_bytes):
    ds = GraspDataset(synthetic, memory_bytes=memory_bytes)
    assert ds.chunk_rows == 512
    positions = [900, 3, 1499, 3, 512, 700, 701, 0]  # unsorted, repeated, across chunks
    batch = ds.__getitems__(positions)
    for k, position in enumerate(positions):
        item = ds[position]
        for name in ("points", "code", "label", "quality", "group"):
            assert torch.equal(batch[name][k], item[name]), (name, position)
    root = zarr.open_group(str(synthetic), mode="r")
    assert np.array_equal(batch["points"][2].numpy(), root["assembled/grasps/points"][1499].astype(np.float32))
    assert ("points" in ds._small) == (memory_bytes > 0)  # 13.5 MB of points: in memory only when allowed


def test_a_loader_with_two_workers_gives_the_batches_of_one_without(synthetic):
    from torch.utils.data import DataLoader

    from onepiece_dist.learn.dataset import collate

    def batches(workers: int) -> list[dict]:
        train, _ = GraspDataset(synthetic).split_by_group(0.2, seed=0)
        loader = DataLoader(train, batch_sampler=ChunkBatchSampler(train, 100, seed=3), collate_fn=collate,
                            num_workers=workers)
        return list(loader)

    serial, parallel = batches(0), batches(2)
    assert len(serial) == len(parallel) > 5
    for a, b in zip(serial, parallel, strict=True):
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_the_sampler_visits_every_row_once_per_epoch_in_batches_that_touch_few_chunks(synthetic):
    ds = GraspDataset(synthetic)
    sampler = ChunkBatchSampler(ds, 64, seed=1)
    batches = list(sampler)
    seen = np.concatenate(batches)
    assert len(batches) == len(sampler) and np.array_equal(np.sort(seen), np.arange(len(ds)))
    per_batch = [len(np.unique(ds.rows[b] // ds.chunk_rows)) for b in batches]
    assert max(per_batch) <= 2 + 2 * 64 // ds.chunk_rows
    assert list(ChunkBatchSampler(ds, 64, seed=1))[0] == batches[0] and list(sampler)[0] != batches[0]


def test_weighting_by_code_count_weighs_each_patch_by_the_grasps_it_stands_for(labelled, tmp_path):
    from onepiece_dist.learn.train import patch_weights

    spec = TrainSpec(model="voxel", epochs=2, batch_size=16, weight_by_count=True)
    weights = patch_weights(labelled, "assembled/grasps", "count")
    counts = zarr.open_group(str(labelled), mode="r")["unique/count"][:]
    assert torch.allclose(weights, torch.from_numpy(counts / counts.mean()).float())
    assert patch_weights(labelled, "assembled/grasps", "none") is None
    plain = train_model(labelled, spec.model_copy(update={"weight_by_count": False}), tmp_path / "a", seed=0)
    weighted = train_model(labelled, spec, tmp_path / "b", seed=0)
    assert plain.metrics[0].train_loss != weighted.metrics[0].train_loss


def test_a_code_only_dataset_is_read_without_points(tmp_path):
    path = synthetic_labelled_dataset(tmp_path / "codes.zarr", rows=100, points=0)
    ds = GraspDataset(path)
    assert ds.inputs == ("code", "quality") and "points" not in ds[0] and ds[0]["code"].shape == (4, 8, 2)
    with pytest.raises(StoreError, match="holds no \\['points'\\]"):
        GraspDataset(path, inputs=("points",))
    result = train_model(path, TrainSpec(model="voxel", epochs=1, batch_size=16), tmp_path / "ckpt")
    assert result.device == "cpu" and len(result.metrics) == 1


def test_the_reader_imports_with_numpy_zarr_and_torch_alone(synthetic):
    blocked = ("ray", "pybullet", "open3d", "pydantic", "typer", "trimesh", "rich")
    code = (f"import sys; sys.modules.update(dict.fromkeys({blocked!r}));"
            "from onepiece_dist.learn import GraspDataset; from onepiece_dist.learn.models import MODELS;"
            f"ds = GraspDataset({str(synthetic)!r}); print(len(ds), MODELS['pointnet']()(ds.batch([0, 1])).shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["1500", "torch.Size([2])"]


def test_device_selection_here_and_for_the_trainer_actor():
    from onepiece_dist.learn.train import resolve_device
    from onepiece_dist.runtime.trainer import trainer_gpus

    assert resolve_device("cpu").type == "cpu"
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError, match="no CUDA GPU"):
            resolve_device("cuda")
    assert [trainer_gpus(d, g) for d, g in [("auto", 0), ("auto", 2), ("cpu", 2), ("cuda", 0)]] == [0, 1, 0, 1]


def test_a_bf16_step_trains_and_checkpoints_load_on_the_cpu(synthetic, tmp_path):
    spec = TrainSpec(model="voxel", epochs=2, batch_size=64, precision="bf16", device="auto")  # ~1 s, not PointNet's 10
    result = train_model(synthetic, spec, tmp_path / "ckpt", seed=0)
    checkpoint = load_checkpoint(result.best_checkpoint)
    assert all(t.device.type == "cpu" for t in checkpoint["state_dict"].values())
    assert np.isfinite(result.metrics[-1].train_loss) and load_model(result.best_checkpoint) is not None
