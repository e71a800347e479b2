"""Simulation for the in-process runner in a process that started without glibc's math functions pinned
(``sim.libm``): such a process cannot pin itself, so its simulations run in one child process started with the
mask, and give the bits every worker gives. A pinned process (the ``onepiece`` command, the test suite, a Ray
worker) runs them itself.

The child is a fresh interpreter running this module (not multiprocessing's "spawn", which would import the
caller's script again in the child). Calls and results go over its stdin and stdout as pickles, between this
process and a child it started, never from a file; the child's own prints go to its stderr.
"""

from __future__ import annotations

import os
import pickle
import struct
import subprocess
import sys
from collections.abc import Callable
from typing import BinaryIO, TypeVar

from onepiece_dist.errors import JobError
from onepiece_dist.sim.libm import libm_pinned, pinned_environment

Result = TypeVar("Result")
_LENGTH = struct.Struct("<Q")


def _send(stream: BinaryIO, value) -> None:
    data = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_LENGTH.pack(len(data)) + data)
    stream.flush()


def _receive(stream: BinaryIO):
    head = stream.read(_LENGTH.size)
    if len(head) < _LENGTH.size:
        raise EOFError("the simulation child ended")
    return pickle.loads(stream.read(_LENGTH.unpack(head)[0]))  # noqa: S301 - our own child's reply, over a pipe


class PinnedSimulation:
    """Calls a function that simulates: here when this process is pinned, else in one pinned child (started at
    the first call, reused, ended by :meth:`close`). The function and its arguments must pickle."""

    def __init__(self) -> None:
        self._child: subprocess.Popen | None = None

    def __call__(self, function: Callable[..., Result], *args) -> Result:
        if libm_pinned():
            return function(*args)
        child = self._started()
        try:
            _send(child.stdin, (function, args))
            ok, value = _receive(child.stdout)
        except (EOFError, BrokenPipeError) as err:
            self.close()
            raise JobError(f"the pinned simulation process died running {function.__name__}") from err
        if not ok:
            raise value
        return value

    def _started(self) -> subprocess.Popen:
        if self._child is None:
            path = os.pathsep.join([entry for entry in sys.path if entry] + [os.environ.get("PYTHONPATH", "")])
            self._child = subprocess.Popen([sys.executable, "-m", __name__], stdin=subprocess.PIPE,
                                           stdout=subprocess.PIPE,
                                           env={**pinned_environment(os.environ), "PYTHONPATH": path})
        return self._child

    def close(self) -> None:
        if self._child is not None:
            self._child.stdin.close()
            self._child.wait()
            self._child = None


def serve() -> None:
    """The child: run each (function, args) read from stdin, reply (True, result) or (False, exception)."""
    replies = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # pybullet and the rest print to stdout: keep it off the reply channel
    requests = sys.stdin.buffer
    while True:
        try:
            function, args = _receive(requests)
        except EOFError:
            return
        try:
            reply = (True, function(*args))
        except Exception as err:  # noqa: BLE001 - the caller raises it
            reply = (False, err)
        _send(replies, reply)


if __name__ == "__main__":
    serve()
