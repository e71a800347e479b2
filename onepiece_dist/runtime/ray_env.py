"""Starting and joining Ray with secure defaults.

* Every Ray we start binds to loopback: with ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` Ray takes 127.0.0.1 as the
  node address, and its GCS, raylet, agents and workers listen there only (Ray 2.60 otherwise resolves the
  machine's address and binds some servers to all interfaces, even when told 127.0.0.1).
* Auth: token authentication, decided here, not left to ``ray.init``: the embedded Ray, the cluster script and our
  cluster clients all run with ``RAY_AUTH_MODE=token`` (unless the user set it), and :func:`connect` makes the
  process's cached Ray config read it again before starting or joining (Ray reads it once per process: a process
  that first talked to a cluster and then started an embedded Ray got a GCS asking for tokens and a driver sending
  none). The token file is made readable by its owner only, and created before an embedded Ray starts: two
  processes that start Ray at once on a machine without a token would each write their own (Ray does not create
  it atomically) and one Ray's workers would then read the other's token.
* The dashboard is off for the embedded Ray; a cluster head started by ``cluster/local_cluster.sh`` serves it on
  127.0.0.1 for the Jobs API.
* Embedded means embedded: without an address we start a fresh Ray of our own (``address="local"``), never
  joining one that Ray would find on the machine (``RAY_ADDRESS``, or the last cluster's file, alive or dead).
  With an address, a cluster that does not answer is reported within seconds, naming the address.
"""

from __future__ import annotations

import os
import secrets
import socket
from pathlib import Path

from onepiece_dist.sim.libm import pin_children

NAMESPACE = "onepiece"
LOOPBACK_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0"}
AUTH_ENV = {"RAY_AUTH_MODE": "token"}  # every Ray we start or join: decided here, not left to ray.init
TOKEN_FILE = Path.home() / ".ray" / "auth_token"
REACH_TIMEOUT_S = 3.0
# The GCS checks each node every second (Ray's default: 3 s): a dead node (its raylet refuses the check) is found
# after 5 failed checks, 5 s instead of 15; a busy one that answers late still has 5 x 10 s of timeouts.
HEALTH_CHECK_PERIOD_MS = 1000


def loopback_environment() -> None:
    """Make Ray processes started from here (and their children) take 127.0.0.1 as the node address, and use
    token auth (unless the environment already says otherwise)."""
    for key, value in {**LOOPBACK_ENV, **AUTH_ENV}.items():
        os.environ.setdefault(key, value)
    import ray._private.ray_constants as constants

    constants.ENABLE_RAY_CLUSTER = os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] not in ("0", "false", "False")


def secure_token_file(path: Path = TOKEN_FILE) -> None:
    """Owner-only permissions on Ray's auth token (Ray writes it world-readable)."""
    if path.exists():
        path.chmod(0o600)


def ensure_token_file(path: Path = TOKEN_FILE) -> str:
    """The auth token at ``path``, created when missing: 256 random bits as hex (Ray's own format), owner-only
    from the start, and published atomically (hard link of a finished file), so that of several processes
    starting at once exactly one token wins and every one of them returns it."""
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        draft = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
        fd = os.open(draft, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            with os.fdopen(fd, "w") as handle:
                handle.write(secrets.token_hex(32))
            os.link(draft, path)
        except FileExistsError:
            pass  # another process published its token first: that one holds
        finally:
            draft.unlink(missing_ok=True)
    return path.read_text()


def connect(address: str | None = None, num_cpus: int | None = None) -> None:
    """Join the cluster at ``address`` ('auto' inside a Ray job), or start an embedded loopback-only Ray."""
    import ray

    if ray.is_initialized():
        return
    loopback_environment()
    pin_children()  # an embedded Ray's raylet and workers start with glibc's math functions pinned (sim.libm)
    refresh_ray_config()
    if address:
        check_reachable(address)
        ray.init(address=address, namespace=NAMESPACE, log_to_driver=False, configure_logging=False)
    else:
        if os.environ["RAY_AUTH_MODE"].lower() == "token":
            ensure_token_file()
        ray.init(address="local", num_cpus=num_cpus, include_dashboard=False, namespace=NAMESPACE,
                 log_to_driver=False, configure_logging=False,
                 _system_config={"health_check_period_ms": HEALTH_CHECK_PERIOD_MS})
    secure_token_file()


def refresh_ray_config() -> None:
    """Make this process's cached Ray config read the environment again (``RAY_AUTH_MODE`` above all), as
    ``ray.init`` does when it turns token auth on by itself; only before this process starts or joins a Ray."""
    from ray._raylet import Config

    Config.initialize("")


def check_reachable(address: str, timeout: float = REACH_TIMEOUT_S) -> None:
    """Raise ConnectionError within ``timeout`` s when nothing listens at a 'host:port' address ('auto', which Ray
    resolves inside a cluster, is left to Ray)."""
    host, _, port = address.rpartition(":")
    if address == "auto" or not host or not port.isdigit():
        return
    try:
        socket.create_connection((host, int(port)), timeout=timeout).close()
    except OSError as err:
        raise ConnectionError(f"nothing answers at {address} ({err.strerror or err})") from None
