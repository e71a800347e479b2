"""Every call made to an actor by name is a method of the plain class that actor runs (issue 48): a client's
``self.call("x")`` or ``self.send("x")``, and the worker pools' methods (``SimWorker.extract``, ``PickWorker.pick``).
Read from the source, so a renamed method fails here, not in the middle of a job on a cluster."""

import ast
import inspect
import textwrap

from onepiece_dist.picks import runner as pick_runner
from onepiece_dist.runtime import ray_runner, registry, trainer, writer
from onepiece_dist.runtime.actors import ActorClient


def called_by_name(cls: type, calls: tuple[str, ...] = ("call", "send")) -> set[str]:
    """The string first arguments of ``self.<one of calls>(...)`` in ``cls``'s own source."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    return {node.args[0].value for node in ast.walk(tree)
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in calls
            and isinstance(node.func.value, ast.Name) and node.func.value.id == "self"
            and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)}


def missing_methods(served: type, names: set[str]) -> set[str]:
    return {name for name in names if name.startswith("_") or not callable(getattr(served, name, None))}


def test_every_method_a_client_calls_by_name_is_a_method_of_the_class_its_actor_runs():
    clients = {trainer.TrainerClient, registry.RegistryClient, writer.WriterClient, ray_runner.RoundTrainer}
    ours = {c for c in ActorClient.__subclasses__() if c.__module__.startswith("onepiece_dist.")}
    assert ours == clients  # a new client is checked too, once it is listed here
    for client in clients:
        names = called_by_name(client)
        assert len(names) >= (1 if client is ray_runner.RoundTrainer else 3), (client, names)  # it sees the calls
        assert missing_methods(client.served, names) == set(), client


def test_the_check_sees_a_call_to_a_method_the_actor_does_not_have():
    class Renamed(ActorClient):
        served = writer.DatasetWriter

        def commit(self, results):
            return self.call("commit_all", results)

        def add(self, codes):
            self.send("add", 0, "", codes)

    assert called_by_name(Renamed) == {"commit_all", "add"}
    assert missing_methods(Renamed.served, called_by_name(Renamed)) == {"commit_all"}


def pool_methods(module, function_name: str) -> set[str]:
    """The worker methods a pool is run with in ``module``: the first string argument of ``function_name(...)``
    (the stage, which names the method) or WorkerPool's fifth (its method)."""
    tree = ast.parse(inspect.getsource(module))
    found = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        position = 0 if name == function_name else 4 if name == "WorkerPool" else None
        if position is not None and len(node.args) > position and isinstance(node.args[position], ast.Constant):
            found.add(node.args[position].value)
    return found


def test_the_worker_pools_call_methods_their_workers_have():
    stages = pool_methods(ray_runner, "_on_pool")
    assert stages == {"extract", "label", "patch"}
    assert missing_methods(ray_runner.SimWorker, stages) == set()
    picks = pool_methods(pick_runner, "_unused")
    assert picks == {"pick"} and missing_methods(pick_runner.PickWorker, picks) == set()
