"""The `onepiece` command line: each command builds a spec and calls one library function.

Exit codes: 0 ok, 1 job failed or cancelled, 2 bad arguments or spec, 3 cluster unreachable.
Machine-readable output (paths, --json) goes to stdout; human output and progress to stderr.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from onepiece_dist.errors import JobError, SourceError, SpecError, StoreError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="ONE PIECE grasp-dataset generation.")

EXIT_FAILED, EXIT_USAGE, EXIT_UNREACHABLE = 1, 2, 3


def _err(message: str) -> None:
    typer.echo(message, err=True)


def build_spec(spec_file: Path | None, overrides: dict[str, Any]):
    """The JobSpec from an optional file plus command-line overrides (None values ignored)."""
    from onepiece_dist.spec import load_job_spec, parse_job_spec

    given = {k: v for k, v in overrides.items() if v is not None}
    if spec_file is not None:
        return load_job_spec(spec_file, given)
    return parse_job_spec(given, "command line")


@app.command()
def run(
    spec_file: Annotated[Path | None, typer.Argument(metavar="[SPEC]", help="YAML or JSON job spec.")] = None,
    objects: Annotated[str | None, typer.Option(help="Object source: built-in set, folder or glob.")] = None,
    out: Annotated[str | None, typer.Option(help="Dataset path (Zarr directory).")] = None,
    grasps: Annotated[int | None, typer.Option(help="Grasp candidates per object.")] = None,
    seed: Annotated[int | None, typer.Option(help="Random seed.")] = None,
    ray: Annotated[bool, typer.Option("--ray", help="Run on an embedded Ray (127.0.0.1, worker actors).")] = False,
) -> None:
    """Run a job end to end and print the dataset path."""
    from onepiece_dist.api import run_job

    try:
        spec = build_spec(spec_file, {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed})
        status = run_job(spec, use_ray=ray, progress=_progress_printer())
    except (SpecError, SourceError) as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    except JobError as err:
        _err(f"job failed: {err}")
        raise typer.Exit(EXIT_FAILED) from None
    for rejection in status.rejections:
        _err(f"rejected {rejection.name}: {rejection.reason}")
    _err(f"{status.progress.objects_done} objects, {status.progress.grasps} grasps, "
         f"{status.progress.unique_codes} unique codes")
    typer.echo(status.output)


def _progress_printer():
    if not sys.stderr.isatty():
        return None
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                   TimeRemainingColumn(), transient=True)
    task = bar.add_task("extract", total=None)
    bar.start()

    def update(status) -> None:
        bar.update(task, completed=status.progress.objects_done, total=status.progress.objects_total,
                   description=status.stage)
        if status.progress.objects_done >= status.progress.objects_total:
            bar.stop()

    return update


@app.command()
def inspect(
    dataset: Annotated[Path, typer.Argument(help="Dataset path.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")] = False,
) -> None:
    """Summarise a dataset: objects, grasps, unique codes, dedup ratio, bytes on disk."""
    from onepiece_dist.store import open_dataset

    try:
        summary = open_dataset(dataset).summary()
    except StoreError as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    if as_json:
        typer.echo(json.dumps(summary))
        return
    for key, value in summary.items():
        typer.echo(f"{key:>16}: {value}")


@app.command()
def schema(
    out: Annotated[Path, typer.Option(help="Folder for the JSON Schemas.")] = Path("schemas"),
) -> None:
    """Write JSON Schemas of the job spec, job status and dataset layout."""
    from onepiece_dist.schemas import write_schemas

    for path in write_schemas(out):
        typer.echo(str(path))


def main() -> None:
    app()


if __name__ == "__main__":
    main()
