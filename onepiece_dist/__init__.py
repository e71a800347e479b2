"""OnePiece-Dist: cheap grasp datasets by the ONE PIECE method, on Ray.

Rooms (imports go downward only; docs/architecture.md, checked by tests/test_layers.py): ``core`` <- ``objects``
<- ``sim``; ``stats``; ``store`` <- ``learn`` <- ``plan``; all of them <- ``job`` <- ``runtime`` <- ``picks``
<- ``api`` <- ``study`` <- ``cli``. ``specs`` (on ``gripper``) and ``errors`` are under every room (``store`` uses
``errors`` only).

The names below load on first use, so ``onepiece_dist.learn.dataset`` (the reader) imports with numpy, zarr and
torch alone.
"""

from onepiece_dist.errors import (
    ActorLost,
    ClusterUnreachable,
    JobCancelled,
    JobError,
    MeshRejected,
    MissingAssembly,
    OnePieceError,
    SpecError,
    StoreError,
)

__version__ = "0.1.0"
_SPEC_NAMES = ("GripperSpec", "JobSpec", "SamplerSpec", "VoxelSpec", "load_job_spec")
__all__ = ["ActorLost", "ClusterUnreachable", "GripperSpec", "JobCancelled", "JobError", "JobSpec", "MeshRejected",
           "MissingAssembly", "OnePieceError", "SamplerSpec", "SpecError", "StoreError", "VoxelSpec", "load_job_spec"]


def __getattr__(name: str):
    if name in _SPEC_NAMES:  # pydantic specs: imported when first asked for
        from onepiece_dist.specs import job

        return getattr(job, name)
    raise AttributeError(f"module 'onepiece_dist' has no attribute {name!r}")
