"""One error family. Each error also inherits the builtin it refines, and its message names the
offending file, field or value."""

from __future__ import annotations


class OnePieceError(Exception):
    """Base of every error this package raises on purpose."""


class SpecError(OnePieceError, ValueError):
    """A job, gripper, voxel or sampler spec is invalid (message names field, value and rule)."""


class SourceError(OnePieceError, ValueError):
    """An object source string or folder cannot be resolved."""


class MeshRejected(OnePieceError, ValueError):
    """One object cannot be used; ``source`` names the file and ``reason`` says why."""

    def __init__(self, source: str, reason: str):
        super().__init__(f"{source}: {reason}")
        self.source = source
        self.reason = reason


class PathEscape(MeshRejected):
    """A path resolves outside the root it must stay in."""


class StoreError(OnePieceError, OSError):
    """A dataset store is missing, incomplete or of an unknown format."""


class JobError(OnePieceError, RuntimeError):
    """A job failed or was cancelled."""


class MissingAssembly(StoreError, FileNotFoundError):
    """A stage or command needs the one object, and the dataset has none: run the assemble stage first."""


class JobCancelled(JobError):
    """A job was cancelled on request."""


class ActorLost(JobError):
    """A central actor (dedup/assembly, trainer, registry) stayed unreachable past its patience."""


class RuntimeLost(JobError):
    """The Ray runtime under a running job went away (node death, raylet or GCS gone). Committed work is kept:
    ``onepiece resume`` finishes the job."""


class ClusterUnreachable(OnePieceError, ConnectionError):
    """No Ray cluster answers at the given address."""


class JobNotFound(OnePieceError, LookupError):
    """No job with this id on the cluster, or no job status at this dataset path."""


class VersionMismatch(OnePieceError, ValueError):
    """The cluster runs another version of the package than the client that submits to it."""


class DriverGone(JobError):
    """The process that drove a job ended without finishing it (killed, or its machine went down)."""


class CloudRejected(OnePieceError, ValueError):
    """An observed point cloud or depth image cannot be planned on; the message names the file, what is
    wrong and the fix."""


class CheckpointRejected(OnePieceError, ValueError):
    """A checkpoint that cannot score a planner's crops (unreadable, not a grasp network, trained for another
    gripper); the message names the file and the fix."""
