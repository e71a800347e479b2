"""The `onepiece` commands for jobs on a cluster (and their local counterparts): submit, status, wait, cancel, logs,
list. With --address they talk to the cluster's Jobs API only (what a port-forward reaches) and read progress from
the cluster's job registry; without it, from the status file beside a dataset."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import (
    EXIT_USAGE,
    Address,
    Grasps,
    JobId,
    Objects,
    Seed,
    SpecFile,
    Stages,
    err,
    exit_codes,
    exit_for,
    print_status,
    spec_or_exit,
    spec_overrides,
)
from onepiece_dist.runtime.ray_env import connect
from onepiece_dist.runtime.registry import CLUSTER_INFO_MARK
from onepiece_dist.runtime.registry import cluster_info as read_cluster

Timeout = Annotated[float | None, typer.Option(help="Give up after this many seconds (exit 4).")]
AsJson = Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")]


def cluster_call(action, address: str | None):
    """``action(Client(address))``, with the CLI's exit code for each way it can fail."""
    from onepiece_dist.api import Client

    with exit_codes(address):
        return action(Client(address))


def submit(
    spec_file: SpecFile = None,
    address: Address = None,
    objects: Objects = None,
    out: Annotated[str | None, typer.Option(help="Dataset path as the cluster's nodes see it; absolute.")] = None,
    grasps: Grasps = None,
    seed: Seed = None,
    stages: Stages = None,
    job_id: JobId = None,
    wait_for_it: Annotated[bool, typer.Option("--wait", help="Wait for the job to end; exit with its code.")] = False,
    timeout: Timeout = None,
    as_json: AsJson = False,
) -> None:
    """Submit a job to a cluster through the Ray Jobs API and print its id (it outlives this command)."""
    if not address:
        err("error: submit needs --address (the cluster's Jobs API, e.g. http://127.0.0.1:8265) or RAY_ADDRESS")
        raise typer.Exit(EXIT_USAGE)
    spec = spec_or_exit(spec_file, spec_overrides(objects, out, grasps, seed, stages))
    handle = cluster_call(lambda c: c.submit(spec, job_id=job_id, runtime_env=_worker_runtime_env()), address)
    if handle.note:
        err(handle.note)
    if not wait_for_it:
        typer.echo(handle.job_id)
        return
    err(f"submitted {handle.job_id}; waiting for it to end")
    final = cluster_call(lambda c: c.wait(handle.job_id, timeout=timeout), address)
    print_status(final, as_json)
    if not as_json:
        typer.echo(handle.job_id)
    exit_for(final.state)


def _worker_runtime_env() -> dict | None:
    """workers/runtime_env.yaml when run from a checkout, else none (nodes run the installed package)."""
    import yaml

    path = Path(__file__).resolve().parents[2] / "workers" / "runtime_env.yaml"
    return yaml.safe_load(path.read_text()) if path.is_file() else None


def status(
    job: Annotated[str, typer.Argument(help="Job id (with --address) or dataset path.")],
    address: Address = None,
    as_json: AsJson = False,
) -> None:
    """Show a job's state, stage and progress (from the cluster's registry with --address)."""
    from onepiece_dist.api import read_status

    current = cluster_call(lambda c: c.status(job), address) if address else _local(read_status, job)
    print_status(current, as_json)


def _local(action, *args):
    with exit_codes():
        return action(*args)


def wait(
    job: Annotated[str, typer.Argument(help="Job id (with --address) or dataset path.")],
    address: Address = None,
    timeout: Timeout = None,
    as_json: AsJson = False,
) -> None:
    """Wait for a job to end; exit 0 if it succeeded, 1 if it failed or was cancelled, 4 on timeout."""
    from onepiece_dist.api import wait_for_dataset

    if address:
        final = cluster_call(lambda c: c.wait(job, timeout=timeout), address)
    else:
        final = _local(wait_for_dataset, job, timeout)  # a driver that is gone: exit 1, with how to resume
    print_status(final, as_json)
    exit_for(final.state)


def cancel(job: Annotated[str, typer.Argument(help="Job id.")], address: Address = None) -> None:
    """Cancel a submitted job (a job started with `onepiece run` stops with Ctrl-C)."""
    if not address:
        err("error: cancel needs --address (or RAY_ADDRESS); a job started with `onepiece run` stops with Ctrl-C")
        raise typer.Exit(EXIT_USAGE)
    state = cluster_call(lambda c: c.cancel(job), address)
    if state in ("succeeded", "failed", "cancelled"):
        err(f"job {job} had already ended ({state}); nothing to cancel")
    else:
        err(f"cancel requested for {job} (it was {state})")


def logs(
    job: Annotated[str, typer.Argument(help="Job id.")],
    address: Address = None,
    follow: Annotated[bool, typer.Option("--follow", "-f", help="Keep printing until the job ends.")] = False,
) -> None:
    """Print a submitted job's driver log (its progress lines among them)."""
    if not address:
        err("error: logs needs --address (or RAY_ADDRESS)")
        raise typer.Exit(EXIT_USAGE)
    if not follow:
        typer.echo(cluster_call(lambda c: c.logs(job), address), nl=False)
        return
    cluster_call(lambda c: c.state(job), address)  # no such job: exit 2 before following nothing

    def follow(client) -> None:
        for chunk in client.follow_logs(job):
            typer.echo(chunk, nl=False)

    cluster_call(follow, address)


def list_jobs(
    address: Address = None,
    folder: Annotated[Path, typer.Option(help="Without --address: where to look for job status files.")] = Path("."),
    as_json: AsJson = False,
) -> None:
    """List jobs: those of a cluster (--address) with their stage and progress, or the status files under a
    folder."""
    if address:
        rows = cluster_call(lambda c: c.jobs(), address)
    else:
        from onepiece_dist.api import local_jobs

        rows = local_jobs(folder)
    if as_json:
        typer.echo(json.dumps(rows))
        return
    for row in rows:
        typer.echo(f"{row['job_id']}\t{row['state']}\t{row['stage']}\t{row['objects_done']}/{row['objects_total']}"
                   f"\t{row['output']}")


def cluster_info(address: Address = None) -> None:
    """(Run inside the cluster by clients.) Print the package version and the job registry as one marked line."""
    connect(address or "auto")
    typer.echo(CLUSTER_INFO_MARK + json.dumps(read_cluster()))


def register(app: typer.Typer) -> None:
    app.command()(submit)
    app.command()(status)
    app.command()(wait)
    app.command()(cancel)
    app.command()(logs)
    app.command(name="list")(list_jobs)
    app.command(name="cluster-info", hidden=True)(cluster_info)
