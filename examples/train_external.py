"""Train a small grasp classifier on a OnePiece-Dist dataset with torch, zarr and our reader only.

Usage: python examples/train_external.py onepiece-out/dataset.zarr [epochs]
Reads the labelled grasps of the one object (assembled/grasps), splits by patch, trains a tiny PointNet.
"""

import sys

import torch
from torch import nn
from torch.utils.data import DataLoader

from onepiece_dist.learn import ChunkBatchSampler, GraspDataset
from onepiece_dist.learn.dataset import collate


class TinyPointNet(nn.Module):
    def __init__(self):
        super().__init__()
        self.point_mlp = nn.Sequential(nn.Conv1d(3, 32, 1), nn.ReLU(), nn.Conv1d(32, 64, 1), nn.ReLU())
        self.head = nn.Linear(64, 1)

    def forward(self, points):  # (n, P, 3) gripper-frame metres
        return self.head(self.point_mlp(points.transpose(1, 2) * 25).max(dim=2).values).squeeze(1)


def main(path: str, epochs: int = 3) -> None:
    torch.manual_seed(0)
    train, val = GraspDataset(path, "assembled/grasps").split_by_group(0.2, seed=0)
    loader = DataLoader(train, batch_sampler=ChunkBatchSampler(train, 32), collate_fn=collate, num_workers=0)
    model, loss_fn = TinyPointNet(), nn.BCEWithLogitsLoss()
    optimiser = torch.optim.Adam(model.parameters(), lr=1e-3)
    for epoch in range(epochs):
        total = 0.0
        for batch in loader:
            optimiser.zero_grad()
            loss = loss_fn(model(batch["points"]), batch["label"])
            loss.backward()
            optimiser.step()
            total += loss.item() * len(batch["label"])
        with torch.no_grad():
            held = collate(val.batch(torch.arange(len(val)).numpy()))
            accuracy = ((model(held["points"]) > 0).float() == held["label"]).float().mean().item()
        print(f"epoch {epoch}: train loss {total / len(train):.3f}, validation accuracy {accuracy:.3f}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "onepiece-out/dataset.zarr",
         int(sys.argv[2]) if len(sys.argv) > 2 else 3)
