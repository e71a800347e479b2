"""Grasp networks: a PointNetGPD-style PointNet on gripper-frame points, and a small 3D CNN on voxel codes.
Both output one logit per grasp (success)."""

from __future__ import annotations

import torch
from torch import nn

from onepiece_dist.core.cloud.swept_space import space_size

# gravity is a unit vector; offsets in m, scaled so that 10 cm is 1; the camera's direction (where the planner
# gives it) a unit vector
CONTEXT_SCALE = torch.tensor([1.0, 1.0, 1.0, 10.0, 10.0, 10.0, 1.0, 1.0, 1.0])


class PointNetGrasp(nn.Module):
    """PointNet classifier: shared per-point MLP (conv1d), max pooling, MLP head. points (n, P, 3) -> (n,).
    With ``context`` > 0 the head also reads ``batch["context"]`` (n, context): the grasp's gravity direction and
    object-centre offset in the gripper frame (core.grasp_context), through a small MLP of its own; with ``space`` > 0
    also ``batch["space"]`` (n, space): the hand's swept space as the camera saw it (core.cloud.swept_space); with
    ``outline`` also ``batch["outline"]`` (n, K, 3): the observed object's points seen from the grasp
    (core.cloud.outline), through a small PointNet of its own."""

    def __init__(self, width: int = 64, context: int = 0, space: int = 0, outline: bool = False):
        super().__init__()
        self.context, self.space, self.outline = context, space, outline
        self.features = _point_features(width)
        extra = width // 2 if context else 0
        if context:
            self.context_features = nn.Sequential(nn.Linear(context, extra), nn.ReLU(), nn.Linear(extra, extra),
                                                  nn.ReLU())
        if space:
            self.space_features = nn.Sequential(nn.Linear(space, 2 * width), nn.ReLU(), nn.Linear(2 * width, width),
                                                nn.ReLU())
            extra += width
        if outline:
            self.outline_features = _point_features(width // 2)
            extra += 2 * width
        self.head = nn.Sequential(nn.Linear(4 * width + extra, 2 * width), nn.ReLU(), nn.Dropout(0.3),
                                  nn.Linear(2 * width, 1))

    def forward(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        x = batch["points"].transpose(1, 2) * 25.0  # metres -> roughly unit scale for a 4 cm region
        pooled = self.features(x).max(dim=2).values
        if self.context:
            context = batch["context"] * CONTEXT_SCALE[: self.context].to(pooled.device)
            pooled = torch.cat([pooled, self.context_features(context)], dim=1)
        if self.space:
            pooled = torch.cat([pooled, self.space_features(batch["space"])], dim=1)
        if self.outline:  # metres -> 10 cm is 1, as the context's offset
            outline = self.outline_features(batch["outline"].transpose(1, 2) * 10.0).max(dim=2).values
            pooled = torch.cat([pooled, outline], dim=1)
        return self.head(pooled).squeeze(1)


def _point_features(width: int) -> nn.Sequential:
    """PointNet's shared per-point MLP: (n, 3, P) -> (n, 4 width, P)."""
    return nn.Sequential(
        nn.Conv1d(3, width, 1), nn.BatchNorm1d(width), nn.ReLU(),
        nn.Conv1d(width, 2 * width, 1), nn.BatchNorm1d(2 * width), nn.ReLU(),
        nn.Conv1d(2 * width, 4 * width, 1), nn.BatchNorm1d(4 * width), nn.ReLU())


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


def PointNetWithContext() -> PointNetGrasp:  # noqa: N802 (a model constructor, named as the classes are)
    """PointNet (width 32: fits on a CPU in minutes) on the crop with the grasp's context (gravity and object
    offset in the gripper frame)."""
    return PointNetGrasp(width=32, context=6)


def WidePointNetWithContext() -> PointNetGrasp:  # noqa: N802
    """The context PointNet at width 64 (four times the compute): does capacity bound the picks?"""
    return PointNetGrasp(width=64, context=6)


def PointNetWithView() -> PointNetGrasp:  # noqa: N802
    """The context PointNet that also reads the direction to the camera in the gripper frame (core.grasp_context):
    which side of the crop was seen and which lies in the unknown, occluded space."""
    return PointNetGrasp(width=32, context=9)


def PointNetWithSpace() -> PointNetGrasp:  # noqa: N802
    """The context PointNet that also reads the hand's swept space as the camera saw it (free, on the surface,
    behind it: core.cloud.swept_space) on a grid around the fingers and palm."""
    return PointNetGrasp(width=32, context=6, space=space_size())


def PointNetWithOutline() -> PointNetGrasp:  # noqa: N802
    """The context PointNet that also reads the observed object's outline seen from the grasp (core.cloud.outline):
    what the object is outside the fingers."""
    return PointNetGrasp(width=32, context=6, outline=True)


def SmallPointNet() -> PointNetGrasp:  # noqa: N802
    """The same PointNet on the crop alone (the context's ablation)."""
    return PointNetGrasp(width=32)


MODELS = {"pointnet": PointNetGrasp, "voxel": VoxelCNN, "pointnet_context": PointNetWithContext,
          "pointnet_context_wide": WidePointNetWithContext, "pointnet_small": SmallPointNet,
          "pointnet_context_view": PointNetWithView, "pointnet_context_space": PointNetWithSpace,
          "pointnet_context_outline": PointNetWithOutline}
# models that read batch["context"]
CONTEXT_MODELS = frozenset({"pointnet_context", "pointnet_context_wide", "pointnet_context_view",
                            "pointnet_context_space", "pointnet_context_outline"})
