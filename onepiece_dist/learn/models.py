"""Grasp networks: a PointNetGPD-style PointNet on gripper-frame points, and a small 3D CNN on voxel codes.
Both output one logit per grasp (success)."""

from __future__ import annotations

import torch
from torch import nn


class PointNetGrasp(nn.Module):
    """PointNet classifier: shared per-point MLP (conv1d), max pooling, MLP head. points (n, P, 3) -> (n,)."""

    def __init__(self, width: int = 64):
        super().__init__()
        self.features = nn.Sequential(
            nn.Conv1d(3, width, 1), nn.BatchNorm1d(width), nn.ReLU(),
            nn.Conv1d(width, 2 * width, 1), nn.BatchNorm1d(2 * width), nn.ReLU(),
            nn.Conv1d(2 * width, 4 * width, 1), nn.BatchNorm1d(4 * width), nn.ReLU())
        self.head = nn.Sequential(nn.Linear(4 * width, 2 * width), nn.ReLU(), nn.Dropout(0.3),
                                  nn.Linear(2 * width, 1))

    def forward(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        x = batch["points"].transpose(1, 2) * 25.0  # metres -> roughly unit scale for a 4 cm region
        return self.head(self.features(x).max(dim=2).values).squeeze(1)


class VoxelCNN(nn.Module):
    """3D CNN on the (a, b, c) occupancy code. code (n, a, b, c) -> (n,)."""

    def __init__(self, width: int = 16):
        super().__init__()
        self.features = nn.Sequential(
            nn.Conv3d(1, width, 3, padding=1), nn.ReLU(),
            nn.Conv3d(width, 2 * width, 3, padding=1), nn.ReLU(),
            nn.AdaptiveMaxPool3d(1))
        self.head = nn.Sequential(nn.Flatten(), nn.Linear(2 * width, width), nn.ReLU(), nn.Linear(width, 1))

    def forward(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        return self.head(self.features(batch["code"].unsqueeze(1))).squeeze(1)


MODELS = {"pointnet": PointNetGrasp, "voxel": VoxelCNN}
