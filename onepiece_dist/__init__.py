"""OnePiece-Dist: cheap grasp datasets by the ONE PIECE method, on Ray.

Layers (imports go downward only; docs/architecture.md, checked by tests/test_layers.py): ``core`` <- ``objects``
<- ``sim``; ``store`` <- ``learn``; all of them <- ``service`` <- ``api`` <- ``cli``. ``spec`` and ``errors`` are
under every layer (``store`` uses ``errors`` only).
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
from onepiece_dist.spec import GripperSpec, JobSpec, SamplerSpec, VoxelSpec, load_job_spec

__version__ = "0.1.0"
__all__ = ["ActorLost", "ClusterUnreachable", "GripperSpec", "JobCancelled", "JobError", "JobSpec", "MeshRejected",
           "MissingAssembly", "OnePieceError", "SamplerSpec", "SpecError", "StoreError", "VoxelSpec", "load_job_spec"]
