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

from onepiece_dist.errors import ClusterUnreachable, JobError, SourceError, SpecError, StoreError

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


Address = Annotated[str | None, typer.Option(help="Ray address: 'auto', 'host:port' (run) or the Jobs API "
                                           "URL 'http://host:8265' (submit, status, wait, cancel, logs, list).")]


@app.command()
def run(
    spec_file: Annotated[Path | None, typer.Argument(metavar="[SPEC]", help="YAML or JSON job spec.")] = None,
    objects: Annotated[str | None, typer.Option(help="Object source: built-in set, folder or glob.")] = None,
    out: Annotated[str | None, typer.Option(help="Dataset path (Zarr directory).")] = None,
    grasps: Annotated[int | None, typer.Option(help="Grasp candidates per object.")] = None,
    seed: Annotated[int | None, typer.Option(help="Random seed.")] = None,
    stages: Annotated[str | None, typer.Option(help="Comma-separated stages, e.g. ingest,extract,dedup.")] = None,
    address: Address = None,
    job_id: Annotated[str | None, typer.Option(help="Job id (default: derived from the spec).")] = None,
    workers: Annotated[int | None, typer.Option(help="Extraction workers (default: the cluster's CPUs).")] = None,
    spec_json: Annotated[str | None, typer.Option(hidden=True, help="The whole spec as JSON (used by submit).")] = None,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run in this process without Ray.")] = False,
) -> None:
    """Run a job end to end (embedded Ray on 127.0.0.1 unless --address) and print the dataset path."""
    overrides = {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed,
                 "stages": stages.split(",") if stages else None}
    spec = _spec_or_exit(spec_file, overrides, spec_json)
    _run_and_report(spec, address, job_id, workers, in_process)


def _spec_or_exit(spec_file: Path | None, overrides: dict, spec_json: str | None = None):
    try:
        if spec_json is not None:
            from onepiece_dist.spec import parse_job_spec

            return parse_job_spec(json.loads(spec_json), "--spec-json")
        return build_spec(spec_file, overrides)
    except (SpecError, json.JSONDecodeError) as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None


def _run_and_report(spec, address, job_id, workers, in_process) -> None:
    from onepiece_dist.api import run_job

    try:
        status = run_job(spec, address=address, in_process=in_process, job_id=job_id, workers=workers,
                         progress=_progress_printer())
    except SourceError as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    except ClusterUnreachable as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_UNREACHABLE) from None
    except JobError as err:
        _err(f"job failed: {err}")
        raise typer.Exit(EXIT_FAILED) from None
    for rejection in status.rejections:
        _err(f"rejected {rejection.name}: {rejection.reason}")
    _err(f"job {status.job_id}: {status.progress.objects_done} objects ({status.progress.objects_reused} reused), "
         f"{status.progress.grasps} grasps, {status.progress.unique_codes} unique codes")
    if status.assembly:
        a = status.assembly
        trials = status.labels.label_trials if status.labels else a.label_trials_one_object
        _err(f"one object: {a.unique_codes} patches, {a.bounding_box_m} m, fidelity {a.fidelity:.1%}, "
             f"{trials} label trials on it (labelling every grasp of every object: {a.label_trials_all_grasps})")
    if status.training:
        t = status.training
        _err(f"trained {t.model} for {t.epochs} epochs: validation accuracy "
             f"{t.final.get('val_accuracy', 0):.2f}, AP {t.final.get('val_ap', 0):.2f}")
    typer.echo(status.output)


@app.command()
def resume(
    job: Annotated[str, typer.Argument(help="The dataset path of the job (its status file holds the spec).")],
    address: Address = None,
    workers: Annotated[int | None, typer.Option(help="Extraction workers.")] = None,
) -> None:
    """Run a job again from its status: committed objects are reused, the rest is extracted."""
    from onepiece_dist.api import read_status
    from onepiece_dist.spec import parse_job_spec

    try:
        status = read_status(job)
        spec = parse_job_spec(status.spec, f"{job} status")
    except (JobError, SpecError) as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    _run_and_report(spec, address, status.job_id, workers, in_process=False)


@app.command()
def submit(
    spec_file: Annotated[Path | None, typer.Argument(metavar="[SPEC]", help="YAML or JSON job spec.")] = None,
    address: Address = None,
    objects: Annotated[str | None, typer.Option(help="Object source.")] = None,
    out: Annotated[str | None, typer.Option(help="Dataset path, as seen by the cluster.")] = None,
    grasps: Annotated[int | None, typer.Option(help="Grasp candidates per object.")] = None,
    seed: Annotated[int | None, typer.Option(help="Random seed.")] = None,
    stages: Annotated[str | None, typer.Option(help="Comma-separated stages, e.g. ingest,extract,dedup.")] = None,
    job_id: Annotated[str | None, typer.Option(help="Job id (default: derived from the spec).")] = None,
) -> None:
    """Submit a job to a cluster through the Ray Jobs API and print its id (it outlives this command)."""
    if not address:
        _err("error: submit needs --address (the cluster's Jobs API, e.g. http://127.0.0.1:8265)")
        raise typer.Exit(EXIT_USAGE)
    spec = _spec_or_exit(spec_file, {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed,
                                     "stages": stages.split(",") if stages else None})
    handle = _cluster_call(lambda c: c.submit(spec, job_id=job_id, runtime_env=_worker_runtime_env()), address)
    typer.echo(handle.job_id)


def _worker_runtime_env() -> dict | None:
    """workers/runtime_env.yaml when run from a checkout, else none (nodes run the installed package)."""
    import yaml

    path = Path(__file__).resolve().parents[1] / "workers" / "runtime_env.yaml"
    return yaml.safe_load(path.read_text()) if path.is_file() else None


def _cluster_call(action, address: str | None):
    from onepiece_dist.api import Client

    try:
        return action(Client(address))
    except ClusterUnreachable as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_UNREACHABLE) from None
    except (ConnectionError, OSError) as err:
        _err(f"error: cluster unreachable at {address}: {err}")
        raise typer.Exit(EXIT_UNREACHABLE) from None


@app.command()
def status(
    job: Annotated[str, typer.Argument(help="Job id (with --address) or dataset path.")],
    address: Address = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")] = False,
) -> None:
    """Show a job's state, stage and progress."""
    from onepiece_dist.api import read_status

    try:
        current = _cluster_call(lambda c: c.status(job), address) if address else read_status(job)
    except JobError as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    _print_status(current, as_json)


def _print_status(current, as_json: bool) -> None:
    if as_json:
        typer.echo(current.model_dump_json())
        return
    p = current.progress
    typer.echo(f"{current.job_id}: {current.state} ({current.stage}) objects {p.objects_done}/{p.objects_total}, "
               f"grasps {p.grasps}, unique codes {p.unique_codes}", err=True)


@app.command()
def wait(
    job: Annotated[str, typer.Argument(help="Job id.")],
    address: Address = None,
    timeout: Annotated[float | None, typer.Option(help="Give up after this many seconds.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")] = False,
) -> None:
    """Wait for a submitted job to end; exit 0 if it succeeded, 1 otherwise."""
    from onepiece_dist.api import JobHandle

    final = _cluster_call(lambda c: JobHandle(c, job, output="").wait(timeout=timeout), address)
    _print_status(final, as_json)
    if final.state != "succeeded":
        raise typer.Exit(EXIT_FAILED)


@app.command()
def cancel(job: Annotated[str, typer.Argument(help="Job id.")], address: Address = None) -> None:
    """Cancel a submitted job."""
    _cluster_call(lambda c: c.cancel(job), address)
    _err(f"cancel requested for {job}")


@app.command()
def logs(job: Annotated[str, typer.Argument(help="Job id.")], address: Address = None) -> None:
    """Print a submitted job's driver log."""
    typer.echo(_cluster_call(lambda c: c.logs(job), address))


@app.command(name="list")
def list_jobs(
    address: Address = None,
    folder: Annotated[Path, typer.Option(help="Without --address: where to look for job status files.")] = Path("."),
    as_json: Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")] = False,
) -> None:
    """List jobs: those of a cluster (--address) or the status files under a folder."""
    if address:
        rows = _cluster_call(lambda c: c.jobs(), address)
    else:
        from onepiece_dist.service.status import STATUS_SUFFIX, JobStatus

        rows = []
        for path in sorted(folder.glob(f"**/*{STATUS_SUFFIX}")):
            found = JobStatus.load(str(path)[: -len(STATUS_SUFFIX)])
            rows.append({"job_id": found.job_id, "state": found.state, "output": found.output})
    if as_json:
        typer.echo(json.dumps(rows))
        return
    for row in rows:
        typer.echo(f"{row['job_id']}\t{row['state']}\t{row['output']}")


def _print_mapping(mapping: dict, as_json: bool) -> None:
    """JSON alone on stdout, or one aligned ``key: value`` line per entry."""
    if as_json:
        typer.echo(json.dumps(mapping))
        return
    width = max((len(k) for k in mapping), default=0)
    for key, value in mapping.items():
        typer.echo(f"{key:>{width}}: {value}")


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
    _print_mapping(summary, as_json)


@app.command()
def export(
    dataset: Annotated[Path, typer.Argument(help="Dataset path.")],
    out: Annotated[Path, typer.Option(help="File to write.")],
    fmt: Annotated[str, typer.Option("--format", help="obj, ply or urdf (the URDF's OBJ is written beside it).")]
    = "obj",
) -> None:
    """Export the assembled one object as OBJ, PLY or URDF."""
    from onepiece_dist.service.assemble import export_assembly

    if fmt not in ("obj", "ply", "urdf"):
        _err(f"error: --format {fmt!r}: expected obj, ply or urdf")
        raise typer.Exit(EXIT_USAGE)
    try:
        written = export_assembly(dataset, fmt, out)
    except StoreError as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    for path in written:
        typer.echo(str(path))


@app.command()
def render(
    dataset: Annotated[Path, typer.Argument(help="Dataset path.")],
    out: Annotated[Path, typer.Option(help="PNG to write.")] = Path("assembly.png"),
    grasps: Annotated[int, typer.Option(min=0, help="Also draw this many labelled grasps on the one object.")] = 0,
    hand: Annotated[str, typer.Option(help="Gripper drawn in those: 'panda' (the Franka hand's meshes from "
                                           "pybullet_data) or 'model' (the simulated boxes).")] = "panda",
) -> None:
    """Draw the assembled object (patches coloured by plane), optionally labelled grasps with the gripper (green
    held, red dropped), and a gallery of codes with their projections."""
    from onepiece_dist.service.render import render_assembly

    try:
        render_assembly(dataset, out, grasps, hand)
    except (StoreError, FileNotFoundError, ValueError) as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    typer.echo(str(out))


@app.command()
def evaluate(
    model: Annotated[Path, typer.Argument(help="Checkpoint (best.pt in <dataset>.train/).")],
    objects: Annotated[str, typer.Option(help="Unseen objects: built-in set, folder or glob.")],
    out: Annotated[str, typer.Option(help="Where to write the labelled evaluation dataset.")] = "onepiece-eval.zarr",
    grasps: Annotated[int, typer.Option(help="Candidates per object.")] = 64,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 1,
    as_json: Annotated[bool, typer.Option("--json", help="Print only JSON on stdout.")] = False,
) -> None:
    """Accuracy and AP on unseen objects, and simulated success of the top-ranked grasp versus a random one."""
    from onepiece_dist.service.evaluate import evaluate_model

    spec = _spec_or_exit(None, {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed})
    try:
        report = evaluate_model(model, spec)
    except (SourceError, StoreError, FileNotFoundError, ValueError) as err:
        _err(f"error: {err}")
        raise typer.Exit(EXIT_USAGE) from None
    _print_mapping(report, as_json)


@app.command()
def supplement(
    scan: Annotated[Path, typer.Argument(help="Point cloud (PLY, PCD, XYZ, XYZN, PTS) or raw mesh (OBJ, STL, "
                                              "PLY, GLB) of a scanned object.")],
    out: Annotated[Path, typer.Option(help="Folder for <name>.obj and <name>.supplement.json; use it as a "
                                           "job's object source.")],
    method: Annotated[str, typer.Option(help="poisson or ball_pivoting.")] = "poisson",
    units: Annotated[str, typer.Option(help="auto, m, cm or mm.")] = "auto",
    max_opening: Annotated[float, typer.Option(help="Gripper opening for the scale check (m).")] = 0.08,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """Turn a scan into a clean, watertight, metre-scaled object mesh, with a report. Exit 1 if refused."""
    from pydantic import ValidationError

    from onepiece_dist.errors import MeshRejected
    from onepiece_dist.objects.supplement import SupplementSpec, supplement_scan
    from onepiece_dist.spec import describe_validation_error

    try:
        options = SupplementSpec(method=method, units=units)
    except ValidationError as err:
        _err(f"error: {describe_validation_error(err, 'command line')}")
        raise typer.Exit(EXIT_USAGE) from None
    try:
        report = supplement_scan(scan, out, options, max_opening)
    except MeshRejected as err:
        _err(f"refused: {err}")
        raise typer.Exit(EXIT_FAILED) from None
    for warning in report.warnings:
        _err(f"warning: {warning}")
    _print_mapping(report.model_dump(), as_json)


@app.command()
def schema(
    out: Annotated[Path, typer.Option(help="Folder for the JSON Schemas.")] = Path("schemas"),
) -> None:
    """Write JSON Schemas of the job spec, job status and dataset layout (and, in a checkout, the array table of
    docs/dataset_format.md)."""
    from onepiece_dist.schemas import refresh_format_page, write_schemas

    for path in write_schemas(out):
        typer.echo(str(path))
    page = Path(__file__).resolve().parents[1] / "docs" / "dataset_format.md"
    if page.is_file():
        refresh_format_page(page)
        typer.echo(str(page))


def main() -> None:
    app()


if __name__ == "__main__":
    main()
