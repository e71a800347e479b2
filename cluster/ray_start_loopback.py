"""`ray start` that keeps 127.0.0.1 as the node address.

Ray 2.60 replaces a loopback --node-ip-address by the machine's address (services.resolve_ip_for_localhost), and
then binds its servers to all interfaces; the only switch that stops it (RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0)
also makes `ray start` refuse worker nodes. This wrapper sets that switch for the processes Ray starts (raylet,
agents, workers, job drivers resolve "localhost" to 127.0.0.1), lifts it in this process alone for the multi-node
check, keeps the given address, and runs `ray start` with the same arguments.
Usage: python cluster/ray_start_loopback.py [ray start arguments...]
"""

import os
import sys

os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"  # inherited by every process Ray starts

import ray._private.ray_constants as constants  # noqa: E402
import ray._private.services as services  # noqa: E402


def keep_address(host: str) -> str:
    if not host:
        raise ValueError(f"Malformed host: {host!r}")
    return host


services.resolve_ip_for_localhost = keep_address
constants.ENABLE_RAY_CLUSTER = True  # here only: allow `ray start --address` (a worker node)

if __name__ == "__main__":
    from ray.scripts.scripts import main

    if "--head" in sys.argv[1:] and os.environ.get("RAY_AUTH_MODE", "").lower() == "token":
        from onepiece_dist.runtime.ray_env import ensure_token_file

        ensure_token_file()  # atomically, before Ray would write one that a Ray starting beside it overwrites

    sys.argv = ["ray", "start", *sys.argv[1:]]
    main()
