"""The deployment files say what the code needs: a GPU worker group for the trainer with the CUDA image."""

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def test_the_raycluster_has_a_gpu_group_for_the_trainer_on_the_cuda_image():
    cluster = yaml.safe_load((ROOT / "deploy" / "raycluster.yaml").read_text())
    groups = {g["groupName"]: g for g in cluster["spec"]["workerGroupSpecs"]}
    gpu = groups["train-gpu"]
    container = gpu["template"]["spec"]["containers"][0]
    assert container["resources"]["limits"]["nvidia.com/gpu"] == "1"
    assert container["image"].endswith("-cuda") and gpu["minReplicas"] == 0
    assert all("nvidia.com/gpu" not in g["template"]["spec"]["containers"][0]["resources"]["limits"]
               for name, g in groups.items() if name != "train-gpu")
    dockerfile = (ROOT / "deploy" / "Dockerfile").read_text()
    assert 'ARG TORCH_INDEX=' in dockerfile and '--index-url "$TORCH_INDEX" torch==2.13.0' in dockerfile
