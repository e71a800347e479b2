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


@pytest.mark.parametrize("model", ["shipped", "pointnet_context_outline"])
def test_a_pick_network_ranks_crops_on_the_gpu_as_on_the_cpu(tmp_path, model):
    """The planner's scorer on the GPU: the same scores as on the CPU to its rounding's last digits, the same best
    grasp (the shipped network, and an untrained network that reads the object's outline). cuDNN's default TF32
    convolutions put the shipped network's scores 1.3e-3 off the CPU's (seen on an H200)."""
    from onepiece_dist.learn.models import MODELS
    from onepiece_dist.plan.scorer import Crops, GraspScorer
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.specs.job import GripperSpec, VoxelSpec

    path = shipped_network()
    if model != "shipped":
        torch.manual_seed(0)
        crop = {"gripper": GripperSpec().model_dump(mode="json"), "voxel": VoxelSpec().model_dump(mode="json"),
                "points_per_grasp": 128}
        path = tmp_path / "outline.pt"
        torch.save({"model": model, "state_dict": MODELS[model]().state_dict(), "crop": crop}, path)
    rng = np.random.default_rng(5)
    n = 700
    context = (rng.normal(size=(n, 6)) * [1, 1, 1, 0.05, 0.05, 0.05]).astype(np.float32)
    crops = Crops(np.zeros((n, 1), np.uint8), np.full(n, 300), (rng.normal(size=(n, 128, 3)) * 0.015).astype(
        np.float16), context, outline=(rng.normal(size=(n, 64, 3)) * 0.05).astype(np.float32))
    on_cpu = GraspScorer(path, device="cpu").score(crops)
    gpu = GraspScorer(path, device="cuda")
    assert gpu.device.type == "cuda"
    on_gpu = gpu.score(crops)
    assert np.abs(on_cpu - on_gpu).max() <= 2e-6 and np.argmax(on_cpu) == np.argmax(on_gpu)
    assert on_cpu.std() > 1e-3  # the crops are told apart: a constant score would pass any comparison
