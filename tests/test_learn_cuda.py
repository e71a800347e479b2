"""The CUDA path of training: run on a machine with a GPU (the device machine), skipped elsewhere. Imports only
the reader-only set plus pydantic, so it runs where ray and pybullet are not installed."""

import numpy as np
import pytest
import torch

from onepiece_dist.learn import GraspDataset
from onepiece_dist.learn.train import load_checkpoint, load_model, predict, resolve_device, train_model
from onepiece_dist.specs.job import TrainSpec
from tests.factories import synthetic_labelled_dataset

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return synthetic_labelled_dataset(tmp_path_factory.mktemp("cuda") / "s.zarr", rows=4000, points=750)


@pytest.mark.parametrize(("model", "precision"), [("pointnet", "fp32"), ("voxel", "bf16")])
def test_training_on_the_gpu_learns_and_leaves_a_checkpoint_that_loads_on_the_cpu(dataset, tmp_path, model,
                                                                                   precision):
    spec = TrainSpec(model=model, epochs=3, batch_size=256, device="auto", precision=precision, loader_workers=2,
                     learning_rate=3e-3)
    assert resolve_device("auto").type == "cuda"
    result = train_model(dataset, spec, tmp_path / "ckpt", seed=0)
    assert result.device == "cuda" and np.isfinite(result.metrics[-1].train_loss)
    checkpoint = load_checkpoint(result.best_checkpoint)
    assert all(t.device.type == "cpu" for t in checkpoint["state_dict"].values())
    model_cpu = load_model(result.best_checkpoint)
    ds = GraspDataset(dataset)
    on_cpu = predict(model_cpu, ds, device=torch.device("cpu"))
    on_gpu = predict(load_model(result.best_checkpoint), ds, device=torch.device("cuda"))
    assert np.allclose(on_cpu, on_gpu, atol=1e-3)


def test_pointnet_learns_the_synthetic_rule_on_the_gpu(dataset, tmp_path):
    spec = TrainSpec(model="pointnet", epochs=8, batch_size=128, device="cuda", learning_rate=3e-3, patience=8)
    result = train_model(dataset, spec, tmp_path / "ckpt", seed=0)
    assert result.metrics[-1].val_accuracy > 0.8
