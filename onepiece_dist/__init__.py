"""OnePiece-Dist: cheap grasp datasets by the ONE PIECE method, on Ray.

Layers (imports go downward only): ``core`` <- ``objects`` <- ``sim`` <- ``store`` <- ``learn`` <- ``service``
<- ``api``, ``cli``. See docs/architecture.md.
"""

from onepiece_dist.errors import JobError, MeshRejected, OnePieceError, SpecError, StoreError
from onepiece_dist.spec import GripperSpec, JobSpec, SamplerSpec, VoxelSpec, load_job_spec

__version__ = "0.1.0"
__all__ = ["GripperSpec", "JobError", "JobSpec", "MeshRejected", "OnePieceError", "SamplerSpec", "SpecError",
           "StoreError", "VoxelSpec", "load_job_spec"]
