"""What every `onepiece` command shares: exit codes, error lines, the spec from file and flags, progress display."""

from __future__ import annotations

import json
import logging
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from onepiece_dist.errors import (
    ClusterUnreachable,
    JobError,
    JobNotFound,
    SourceError,
    SpecError,
    VersionMismatch,
)
from onepiece_dist.gripper.presets import PRESETS, gripper_fields

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_UNREACHABLE, EXIT_TIMEOUT = 0, 1, 2, 3, 4
EXIT_CODES = {EXIT_OK: "ok", EXIT_FAILED: "the job failed or was cancelled (a refused scan, for supplement; no "
                                          "object loaded, for pick and pick-labels)",
              EXIT_USAGE: "usage or input error: bad arguments or spec, unknown source, no such job or dataset, "
                          "relative output for a cluster, package version differs from the cluster's",
              EXIT_UNREACHABLE: "cluster unreachable", EXIT_TIMEOUT: "timed out (wait, submit --wait)"}
EXIT_TABLE = "Exit codes: " + "; ".join(f"{code} {meaning}" for code, meaning in EXIT_CODES.items()) + "."

Address = Annotated[str | None, typer.Option(
    envvar="RAY_ADDRESS", show_envvar=True,
    help="Ray address: 'auto' or 'host:port' (run, resume) or the Jobs API URL 'http://host:8265' (submit, "
         "status, wait, cancel, logs, list). Default: embedded Ray on 127.0.0.1 (run) or the local status file.")]


def err(message: str) -> None:
    typer.echo(message, err=True)


def spec_default(field: str) -> str:
    """A JobSpec field's default, for --help."""
    from onepiece_dist.specs.job import JobSpec

    return f"(default: {JobSpec.model_fields[field].default})"


def build_spec(spec_file: Path | None, overrides: dict[str, Any]):
    """The JobSpec from an optional file plus command-line overrides (None values ignored)."""
    from onepiece_dist.specs.job import load_job_spec, parse_job_spec

    given = {k: v for k, v in overrides.items() if v is not None}
    if spec_file is not None:
        return load_job_spec(spec_file, given)
    return parse_job_spec(given, "command line")


SpecFile = Annotated[Path | None, typer.Argument(metavar="[SPEC]", help="YAML or JSON job spec.")]
Objects = Annotated[str | None, typer.Option(help=f"Object source: built-in set, folder or glob. "
                                                  f"{spec_default('objects')}")]
Grasps = Annotated[int | None, typer.Option(help=f"Grasp candidates per object. {spec_default('grasps_per_object')}")]
Seed = Annotated[int | None, typer.Option(help=f"Random seed. {spec_default('seed')}")]
Stages = Annotated[str | None, typer.Option(help="Comma-separated stages, e.g. ingest,extract,dedup. (default: all)")]
JobId = Annotated[str | None, typer.Option(help="Job id (default: derived from the spec).")]


def spec_overrides(objects: str | None, out: str | None, grasps: int | None, seed: int | None,
                   stages: str | None) -> dict[str, Any]:
    """The spec fields that the job options of run and submit set (None: keep the spec's)."""
    return {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed,
            "stages": stages.split(",") if stages else None}


def spec_or_exit(spec_file: Path | None, overrides: dict, spec_json: str | None = None):
    try:
        if spec_json is not None:
            from onepiece_dist.specs.job import parse_job_spec

            return parse_job_spec(json.loads(spec_json), "--spec-json")
        return build_spec(spec_file, overrides)
    except (SpecError, json.JSONDecodeError) as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None


def print_status(current, as_json: bool) -> None:
    if as_json:
        typer.echo(current.model_dump_json())
        return
    p = current.progress
    line = (f"{current.job_id}: {current.state} ({current.stage}) objects {p.objects_done}/{p.objects_total}, "
            f"grasps {p.grasps}, unique codes {p.unique_codes or '-'}")
    err(line + (f"; error: {current.error}" if current.error else ""))


@contextmanager
def exit_codes(address: str | None = None) -> Iterator[None]:
    """Turn the library's errors into one line on stderr and the CLI's exit code (the table above). Connection
    errors count as an unreachable cluster only when talking to one (``address``)."""
    try:
        yield
    except (JobNotFound, SpecError, SourceError, VersionMismatch) as error:
        _fail(EXIT_USAGE, f"error: {error}")
    except TimeoutError as error:
        _fail(EXIT_TIMEOUT, f"timed out: {error}")
    except ClusterUnreachable as error:
        _fail(EXIT_UNREACHABLE, f"error: {error}")
    except JobError as error:
        _fail(EXIT_FAILED, f"job failed: {error}")
    except (ConnectionError, OSError) as error:
        if address is None:
            raise
        _fail(EXIT_UNREACHABLE, f"error: cluster unreachable at {address}: {error}")


def _fail(code: int, message: str) -> None:
    err(message)
    raise typer.Exit(code) from None


def exit_for(state: str) -> None:
    if state != "succeeded":
        raise typer.Exit(EXIT_FAILED)


class _StderrLines(logging.Handler):
    """Log records as lines on the current ``sys.stderr`` (looked up at each record, so tests can capture it)."""

    def emit(self, record: logging.LogRecord) -> None:
        sys.stderr.write(self.format(record) + "\n")


class ProgressDisplay:
    """A job's progress on stderr, every stage: a rich bar on a terminal, else one log line per event (what a Ray
    job's log shows). A context manager: the bar is stopped (the cursor shown again) however the job ends."""

    def __init__(self, enabled: bool = True):
        self.enabled, self.bar, self.task, self.handler = enabled, None, None, None

    def __enter__(self) -> ProgressDisplay:
        if self.enabled and sys.stderr.isatty():
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("{task.description:<8}"), BarColumn(), TextColumn("{task.fields[count]}"),
                                TimeElapsedColumn(), console=Console(stderr=True), transient=True)
            self.task = self.bar.add_task("ingest", total=None, count="")
            self.bar.start()
        elif self.enabled:
            self.handler = _StderrLines()
            self.handler.setFormatter(logging.Formatter("%(asctime)s %(message)s", "%H:%M:%S"))
            logger = logging.getLogger("onepiece_dist")
            logger.addHandler(self.handler)
            logger.setLevel(logging.INFO)
        return self

    def __call__(self, status) -> None:
        if self.bar is None:
            return
        p = status.progress
        counted = status.stage == "extract" and p.objects_total
        self.bar.update(self.task, description=status.stage, total=p.objects_total if counted else None,
                        completed=p.objects_done if counted else 0,
                        count=f"{p.objects_done}/{p.objects_total} objects" if counted else "")

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.stop()
        if self.handler is not None:
            logging.getLogger("onepiece_dist").removeHandler(self.handler)


def gripper_option(path: Path | None):
    """A --gripper option: a preset's name or a YAML gripper spec (None: not given); exit 2 naming it when it is
    neither."""
    if path is None:
        return None
    import yaml

    from onepiece_dist.specs.job import GripperSpec

    try:
        if not path.exists():
            if str(path) in PRESETS:  # a preset's name: --gripper panda
                return GripperSpec.model_validate(gripper_fields(str(path)))
            raise OSError(f"no such file, nor a preset ({', '.join(sorted(PRESETS))})")
        return GripperSpec.model_validate(gripper_fields(yaml.safe_load(path.read_text()) or {}))
    except (OSError, yaml.YAMLError, ValueError) as error:
        err(f"error: {path}: not a gripper spec: {error}")
        raise typer.Exit(EXIT_USAGE) from None


def spec_mapping(path: Path | None) -> dict:
    """A --spec YAML file's fields ({} where none is given); exit 2 naming it when it is not a mapping."""
    if path is None:
        return {}
    import yaml

    try:
        data = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as error:
        err(f"error: {path}: cannot read the pick spec: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    if not isinstance(data, dict):
        err(f"error: {path}: a pick spec is a mapping of fields")
        raise typer.Exit(EXIT_USAGE)
    return data
