"""Ray actors behind thin clients: the plain classes (central actor, registry, trainer) never see Ray, and
callers never see ``.remote``, ``ray.get``, the restart wait or Ray's exceptions.

A client call waits while its actor restarts (its state is rebuilt from the store) for up to ``patience_s``,
then raises :class:`~onepiece_dist.errors.ActorLost`, one of the package's errors.
"""

from __future__ import annotations

import time
from typing import ClassVar

from onepiece_dist.errors import ActorLost, RuntimeLost
from onepiece_dist.runtime.ray_env import NAMESPACE
from onepiece_dist.sim.libm import worker_environment

ACTOR_PATIENCE_S = 120.0  # how long a central actor may take to come back
RETRY_SECONDS = 0.5


def runtime_alive() -> bool:
    """Whether the connected Ray still has a live node for actors to restart on (False when the GCS is gone)."""
    import ray

    try:
        return any(node.get("Alive") for node in ray.nodes())
    except Exception:  # noqa: BLE001 - any failure to reach the GCS means the runtime is gone
        return False


def restartable_actor(cls, name: str, **options):
    """A named actor class of ``cls`` that Ray restarts when it dies; its methods are not retried by Ray (the
    caller decides what to run again). Its process starts with glibc's math functions pinned (``sim.libm``) on
    whichever node it lands, whatever that node was started with."""
    import ray


    return ray.remote(cls).options(name=name, namespace=NAMESPACE, max_restarts=-1, max_task_retries=0,
                                   runtime_env={"env_vars": worker_environment()}, **options)


class ActorClient:
    """Calls the methods of one actor handle; ``what`` names the actor in errors. ``served`` is the plain class
    the actor runs: every method a client calls by name is one of its methods (tests/test_actors.py)."""

    served: ClassVar[type]

    def __init__(self, handle, what: str, patience_s: float = ACTOR_PATIENCE_S):
        self.handle, self.what, self.patience_s = handle, what, patience_s

    def call(self, method: str, *args):
        """Run ``method(*args)`` on the actor and return its result, waiting out restarts."""
        import ray
        from ray.exceptions import RayActorError

        deadline = time.monotonic() + self.patience_s
        while True:
            try:
                return ray.get(getattr(self.handle, method).remote(*args))
            except RayActorError as err:
                if not runtime_alive():
                    raise RuntimeLost(f"the Ray runtime is gone ({self.what} during {method}: "
                                      f"{type(err).__name__})") from err
                if time.monotonic() > deadline:
                    raise ActorLost(f"{self.what} unreachable for {self.patience_s:.0f} s during {method}: "
                                    f"{type(err).__name__}") from err
                time.sleep(RETRY_SECONDS)

    def send(self, method: str, *args) -> None:
        """Queue ``method(*args)`` on the actor without waiting (best effort: a message to a dead actor is lost)."""
        getattr(self.handle, method).remote(*args)

    def kill(self) -> None:
        import ray

        ray.kill(self.handle)
