"""A trained network as a planner uses it: the checkpoint (loaded with ``weights_only``), the crop it was trained on
(gripper, voxel grid, points per grasp), and scoring of crops cut from an observed cloud, in batches, on a GPU
when there is one."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.cloud import import_planning_libraries
from onepiece_dist.core.cloud.outline import OUTLINE_MODELS
from onepiece_dist.core.cloud.swept_space import SPACE_MODELS
from onepiece_dist.core.voxel import crop_regions, network_inputs, unpack_codes
from onepiece_dist.errors import CheckpointRejected, CloudRejected
from onepiece_dist.specs.job import GripperSpec, VoxelSpec

SCORE_DECIMALS = 6
REGION = ("closing_depth", "closing_width", "closing_height")  # the gripper fields a crop is cut by
CPU_BATCH, GPU_BATCH = 16, 512  # crops per call: 16 scored fastest on one core (0.45 s for 211 crops, 256: 0.68 s)


@dataclass(frozen=True)
class CropRecord:
    """How a network's training crops were cut: by ``gripper`` at ``voxel``, ``points_per_grasp`` points each."""

    gripper: GripperSpec
    voxel: VoxelSpec
    points_per_grasp: int
    model: str

    def grid_shape(self) -> tuple[int, int, int]:
        return self.voxel.grid_shape(self.gripper)


@dataclass(frozen=True)
class Crops:
    """Crops of n poses: codes (n, B) uint8, counts (n,) int64 observed points inside, points (n, P, 3) float16,
    and where the planner knows it, each grasp's context (n, 6) float32 (core.grasp_context) and, where it knows
    the camera's position, the hand's swept space as the camera saw it (n, G) float32 (core.cloud.swept_space), and
    the object's outline seen from each grasp (n, K, 3) float32 (core.cloud.outline)."""

    codes: np.ndarray
    counts: np.ndarray
    points: np.ndarray
    context: np.ndarray | None = None
    space: np.ndarray | None = None
    outline: np.ndarray | None = None

    def holding(self, min_points: int) -> tuple[Crops, np.ndarray]:
        """The crops with at least ``min_points`` observed points inside, and (n,) bool which they were."""
        keep = self.counts >= min_points
        return self.subset(keep), keep

    def subset(self, which: np.ndarray) -> Crops:
        """The crops ``which`` (a bool mask or indices) selects."""
        context, space, outline = (None if values is None else values[which]
                                   for values in (self.context, self.space, self.outline))
        return Crops(self.codes[which], self.counts[which], self.points[which], context, space, outline)


def cut_crops(cloud: np.ndarray, poses: np.ndarray, record: CropRecord, rng: np.random.Generator) -> Crops:
    """Each pose's crop of ``cloud`` (m, 3), exactly as a job's extraction cuts its training crops: the closing
    region's points in the gripper frame (core.voxel.crop_regions) and the network's inputs from them
    (core.voxel.network_inputs: the voxel code, canonical when the training's was, and P resampled points)."""
    grid = record.grid_shape()
    codes, counts, inside = crop_regions(cloud, poses, grid, record.voxel.resolution, keep_points=True)
    codes, points = network_inputs(codes, inside or [], grid, record.voxel.canonical,
                                   max(record.points_per_grasp, 1), rng)
    return Crops(codes, counts, points)


class GraspScorer:
    """A checkpoint ready to score crops. ``gripper``: the gripper the caller plans for; a checkpoint trained for
    another is refused (its crops would mean other shapes), unless ``carried``: then its grasps are proposed for
    ``gripper`` and its crops cut in its own closing region (plan.shipped.planning_network carries the default job's
    network to a hand whose closing region holds its own; docs/picks.md says what that picks)."""

    def __init__(self, checkpoint: str | os.PathLike, gripper: GripperSpec | None = None, device: str = "auto",
                 carried: bool = False):
        from onepiece_dist.learn.models import CONTEXT_MODELS
        from onepiece_dist.learn.train import read_network, resolve_device

        self.path = str(checkpoint)
        saved = read_network(self.path)
        self.record = _crop_record(saved, gripper, carried)
        self.device = resolve_device(device)
        self.reads_context = saved.model in CONTEXT_MODELS
        self.reads_space = saved.model in SPACE_MODELS
        self.reads_outline = saved.model in OUTLINE_MODELS
        self.model = saved.build().to(self.device)
        import_planning_libraries()  # a robot's first plan is planning, not imports

    @property
    def gripper(self) -> GripperSpec:
        return self.record.gripper

    def score(self, crops: Crops, batch_size: int | None = None) -> np.ndarray:
        """(n,) float64 success probabilities of the crops, ``batch_size`` at a time (default: CPU_BATCH on a CPU,
        GPU_BATCH on a GPU)."""
        import torch

        batch_size = batch_size or (GPU_BATCH if self.device.type == "cuda" else CPU_BATCH)
        scores = []
        grid = self.record.grid_shape()
        # cuDNN's convolutions default to TF32 on a GPU (10-bit mantissas: scores 1e-3 off the CPU's, enough to
        # reorder a plan's near ties): full float32, as on a CPU
        with torch.inference_mode(), torch.backends.cudnn.flags(enabled=True, allow_tf32=False):
            for start in range(0, len(crops.counts), batch_size):
                stop = start + batch_size
                if self.record.model == "voxel":
                    code = unpack_codes(crops.codes[start:stop], grid).astype(np.float32)
                    batch = {"code": torch.from_numpy(code).to(self.device)}
                else:
                    batch = {"points": torch.from_numpy(crops.points[start:stop].astype(np.float32)).to(self.device)}
                if self.reads_context:
                    batch["context"] = torch.from_numpy(self._context(crops)[start:stop]).to(self.device)
                if self.reads_space:
                    batch["space"] = torch.from_numpy(self._space(crops)[start:stop]).to(self.device)
                if self.reads_outline:
                    outline = self._input(crops.outline, "the object's outline seen from each grasp",
                                          "plan them with plan.propose, which computes it")
                    batch["outline"] = torch.from_numpy(outline[start:stop]).to(self.device)
                scores.append(torch.sigmoid(self.model(batch)).float().cpu().numpy())
        # rounded: the last bits of a sum depend on the CPU's kernels and threads, and must not reorder near ties
        return np.round(np.concatenate(scores).astype(np.float64), SCORE_DECIMALS) if scores else np.zeros(0)


    def _context(self, crops: Crops) -> np.ndarray:
        return self._input(crops.context, "each grasp's context (gravity and the object's centre in the gripper "
                           "frame)", "plan them with plan.propose, which computes it")

    def _space(self, crops: Crops) -> np.ndarray:
        return self._input(crops.space, "the hand's swept space as the camera saw it", "give the camera's position "
                           "(--viewpoint, or a depth image with its pose) and plan them with plan.propose, which "
                           "computes it")

    def _input(self, values: np.ndarray | None, what: str, fix: str) -> np.ndarray:
        if values is None:
            raise CloudRejected(f"{self.path}: this network reads {what}, and these crops carry none: {fix}")
        return np.ascontiguousarray(values, dtype=np.float32)


def _crop_record(saved, gripper: GripperSpec | None, carried: bool = False) -> CropRecord:
    """The crop ``saved`` (learn.train.SavedNetwork) was trained on, checked against the caller's ``gripper``
    (``carried``: ``gripper`` cutting that crop's region)."""
    path, crop = saved.path, saved.crop
    if crop is None:
        if gripper is None:
            raise CheckpointRejected(f"{path}: the checkpoint does not say which gripper it was trained for (trained "
                                     "before checkpoints kept their crop): name the gripper (--gripper FILE)")
        return CropRecord(gripper, VoxelSpec(), 750, saved.model)
    trained = GripperSpec.model_validate(crop["gripper"])
    voxel, points = VoxelSpec.model_validate(crop["voxel"]), int(crop["points_per_grasp"])
    if gripper is None or gripper == trained:
        return CropRecord(trained, voxel, points, saved.model)
    differs = [name for name in GripperSpec.model_fields if getattr(gripper, name) != getattr(trained, name)]
    if differs == ["name"]:  # the same hand under another name
        return CropRecord(trained, voxel, points, saved.model)
    if carried:  # the network's own region, cut by the caller's hand
        region = {name: getattr(trained, name) for name in REGION}
        return CropRecord(gripper.model_copy(update=region), voxel, points, saved.model)
    raise CheckpointRejected(f"{path}: the checkpoint was trained for another gripper (it differs in "
                             f"{', '.join(differs)}: trained {', '.join(f'{n}={getattr(trained, n)}' for n in differs)}"
                             "): plan with the checkpoint's gripper, or train a network for this one")
