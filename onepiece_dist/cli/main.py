"""The `onepiece` command line: each command builds a spec and calls one library function.

Machine-readable output (paths, --json) goes to stdout; human output and progress to stderr. Exit codes: see
``cli.common.EXIT_CODES`` (printed by --help and in the README).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import (
    EXIT_FAILED,
    EXIT_TABLE,
    EXIT_USAGE,
    Address,
    Grasps,
    JobId,
    Objects,
    ProgressDisplay,
    Seed,
    SpecFile,
    Stages,
    err,
    exit_codes,
    spec_default,
    spec_or_exit,
    spec_overrides,
)
from onepiece_dist.cli.jobs import register as register_job_commands
from onepiece_dist.cli.label import register as register_label_commands
from onepiece_dist.cli.pick_network import register as register_pick_network_commands
from onepiece_dist.cli.plan import register as register_plan_commands
from onepiece_dist.cli.study import study_app
from onepiece_dist.errors import JobError, JobNotFound, MeshRejected, SourceError, SpecError, StoreError
from onepiece_dist.sim.libm import restart_pinned
from onepiece_dist.version import package_version

app = typer.Typer(add_completion=False, no_args_is_help=True, help="ONE PIECE grasp-dataset generation.",
                  epilog=EXIT_TABLE)
register_job_commands(app)
register_plan_commands(app)
register_pick_network_commands(app)
register_label_commands(app)
app.add_typer(study_app, name="study")
_err = err


def _version(value: bool) -> None:
    if value:
        typer.echo(f"onepiece-dist {package_version()}")
        raise typer.Exit()


@app.callback()
def main_options(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the package version and exit.")] = False,
) -> None:
    """ONE PIECE grasp-dataset generation."""


@app.command()
def run(
    spec_file: SpecFile = None,
    objects: Objects = None,
    out: Annotated[str | None, typer.Option(help=f"Dataset path (Zarr directory). {spec_default('output')}")] = None,
    grasps: Grasps = None,
    seed: Seed = None,
    stages: Stages = None,
    address: Address = None,
    job_id: JobId = None,
    workers: Annotated[int | None, typer.Option(help="Extraction workers (default: the cluster's CPUs).")] = None,
    spec_json: Annotated[str | None, typer.Option(hidden=True, help="The whole spec as JSON (used by submit).")] = None,
    final_status: Annotated[bool, typer.Option(hidden=True, help="Log the final status (submit).")] = False,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run in this process without Ray.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the final status as JSON on stdout.")] = False,
    units: Annotated[str | None, typer.Option(help="Units of the object files: m, cm or mm (default: m).")] = None,
    scale: Annotated[float | None, typer.Option(help="A further scale of the object files (default: 1).")] = None,
) -> None:
    """Run a job end to end (embedded Ray on 127.0.0.1 unless --address) and print the dataset path."""
    overrides = {**spec_overrides(objects, out, grasps, seed, stages), "units": units, "scale": scale}
    spec = spec_or_exit(spec_file, overrides, spec_json)
    _run_and_report(spec, address, job_id, workers, in_process, as_json, final_status)


def _run_and_report(spec, address, job_id, workers, in_process, as_json: bool = False,
                    final_status: bool = False) -> None:
    from onepiece_dist.api import run_job

    if address and address.startswith(("http://", "https://")):
        _err(f"error: run drives the job from here and needs a Ray address ('auto' or host:port), not the Jobs API "
             f"URL {address}; to run it on the cluster, use `onepiece submit`")
        raise typer.Exit(EXIT_USAGE)
    with exit_codes(), ProgressDisplay() as display:
        status = run_job(spec, address=address, in_process=in_process, job_id=job_id, workers=workers,
                         progress=display)
    for rejection in status.rejections:
        _err(f"rejected {rejection.name}: {rejection.reason}")
    _err(f"job {status.job_id}: {status.progress.objects_done} objects ({status.progress.objects_reused} reused), "
         f"{status.progress.grasps} grasps, {status.progress.unique_codes} unique codes")
    if status.assembly:
        a = status.assembly
        trials = status.labels.label_trials if status.labels else a.label_trials_one_object
        _err(f"one object: {a.unique_codes} patches, {a.bounding_box_m} m, fidelity {a.fidelity:.1%}, "
             f"{trials} label trials on it (labelling every grasp of every object: {a.label_trials_all_grasps})")
    if status.labels and not status.assembly:
        labels = status.labels
        plan = "adaptive" if status.adaptive else "budget"
        _err(f"{plan}: {labels.labelled_grasps} of {status.progress.grasps} candidates labelled on their own objects "
             f"({labels.label_trials} label trials, success rate {labels.success_rate:.2f})")
    if status.adaptive:
        rounds = status.adaptive.rounds
        _err(f"adaptive: {len(rounds)} rounds, stopped by {status.adaptive.stopped}; validation AP by round "
             + ", ".join(f"{r.validation_ap:.3f} ({r.labels} labels)" for r in rounds))
    if status.training:
        t = status.training
        accuracy, ap = (t.final.val_accuracy, t.final.val_ap) if t.final else (0.0, 0.0)
        _err(f"trained {t.model} for {t.epochs} epochs: on its own validation split (held-back grasps of the "
             f"train data) accuracy {accuracy:.2f}, AP {ap:.2f}")
    if status.evaluation:
        e = status.evaluation
        _err(f"held-out: {e.objects} unseen objects, {e.grasps} candidates (positive rate {e.positive_rate:.2f}): "
             f"top-1 success {e.top1:.2f}{_interval(e.top1_interval)} against random choice {e.random_choice:.2f}"
             f"{_interval(e.random_choice_interval)}, AP {e.ap:.2f} against {e.positive_rate:.2f} for random scores")
        _err(f"held-out protocol: {e.protocol}; {e.verdict}")
    if status.training:
        _err(_next_step(status.training.checkpoint))
    if final_status:  # what a client reads of a job that ended, without a Ray job of its own (api.Client.status)
        _err(status.log_line())
    typer.echo(status.model_dump_json() if as_json else status.output)


def _next_step(checkpoint: str) -> str:
    """Where a trained network goes next: planning on a camera's view, beside the network that ships for it."""
    from onepiece_dist.plan.shipped import shipped_summary

    shipped = shipped_summary().removeprefix("planning with ")
    return (f"grasps on a camera's view with this network: onepiece grasp depth.png --intrinsics k.json "
            f"--checkpoint {checkpoint}; without --checkpoint, with {shipped}; a network trained on pick labels of "
            "your own objects and gripper: onepiece pick-labels --objects YOURS --gripper GRIPPER, then onepiece "
            "pick-train (docs/planning.md)")


def _interval(pair: tuple[float, float] | None) -> str:
    return "" if pair is None else f" [{pair[0]:.2f}, {pair[1]:.2f}]"


@app.command()
def resume(
    job: Annotated[str, typer.Argument(help="The dataset path of the job (its status file holds the spec).")],
    address: Address = None,
    workers: Annotated[int | None, typer.Option(help="Extraction workers.")] = None,
) -> None:
    """Run a job again from its status: committed objects are reused, the rest is extracted."""
    from onepiece_dist.api import read_status
    from onepiece_dist.specs.job import parse_job_spec

    try:
        status = read_status(job)
        spec = parse_job_spec(status.spec, f"{job} status")
    except (JobNotFound, SpecError) as error:
        _err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    _run_and_report(spec, address, status.job_id, workers, in_process=False)


def _print_mapping(mapping: dict, as_json: bool) -> None:
    """JSON alone on stdout, or one aligned ``key: value`` line per entry."""
    if as_json:
        typer.echo(json.dumps(mapping))
        return
    width = max((len(k) for k in mapping), default=0)
    for key, value in mapping.items():
        typer.echo(f"{key:>{width}}: {value}")


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


FOLDER_FORMATS = ("acronym", "graspgen", "urdf-patches", "delivered")  # these write a folder


@app.command()
def export(
    dataset: Annotated[Path, typer.Argument(help="Dataset path.")],
    out: Annotated[Path, typer.Option(help="File to write (obj, ply, urdf) or folder (acronym, graspgen, "
                                           "urdf-patches); nothing is written outside it.")],
    fmt: Annotated[str, typer.Option("--format", help="obj, ply or urdf: the one object (the URDF's OBJs beside "
                                     "it); acronym: an HDF5 file per object; graspgen: a JSON file per object and "
                                     "split lists; urdf-patches: a URDF per patch and a scene file; delivered: a "
                                     "copy of the dataset without its extraction records.")] = "obj",
    valid_fraction: Annotated[float, typer.Option(help="graspgen: share of the objects in valid.txt (seeded by "
                                                       "the job's seed).")] = 0.2,
    valid_objects: Annotated[str, typer.Option(help="graspgen: comma-separated object names for valid.txt "
                                                    "instead.")] = "",
) -> None:
    """Export the one object (OBJ, PLY, URDF, a URDF per patch) or the labelled grasps in ACRONYM's or GraspGen's
    format (docs/dataset_format.md, Other formats)."""
    from onepiece_dist.job.stages.assemble import export_assembly

    formats = ("obj", "ply", "urdf", *FOLDER_FORMATS)
    if fmt not in formats:
        _err(f"error: --format {fmt!r}: expected one of {', '.join(formats)}")
        raise typer.Exit(EXIT_USAGE)
    try:
        if fmt == "acronym":
            from onepiece_dist.job.exports.grasp_files import export_acronym

            written = export_acronym(dataset, out)
        elif fmt == "graspgen":
            from onepiece_dist.job.exports.grasp_files import export_graspgen

            chosen = tuple(name.strip() for name in valid_objects.split(",") if name.strip())
            written = export_graspgen(dataset, out, valid_fraction, chosen)
        elif fmt == "delivered":
            from onepiece_dist.store.dataset import copy_delivered

            written = [copy_delivered(dataset, out)]
        elif fmt == "urdf-patches":
            from onepiece_dist.job.exports.patch_urdfs import export_patches

            written = export_patches(dataset, out)
        else:
            written = export_assembly(dataset, fmt, out)
    except (StoreError, MeshRejected) as err:
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
    from onepiece_dist.job.exports.render import render_assembly

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
    import onepiece_dist.api as api

    spec = spec_or_exit(None, {"objects": objects, "output": out, "grasps_per_object": grasps, "seed": seed})
    try:
        report = api.evaluate_model(model, spec)
    except (SourceError, StoreError, FileNotFoundError, ValueError) as error:
        _err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    except JobError as error:
        _err(f"evaluation failed: {error}")
        raise typer.Exit(EXIT_FAILED) from None
    _print_mapping({**report.model_dump(), "top_ranked_success": report.top1,  # the names it printed first
                    "random_choice_success": report.random_choice, "label_positive_rate": report.positive_rate},
                   as_json)


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

    from onepiece_dist.objects.supplement import SupplementSpec, supplement_scan
    from onepiece_dist.specs.job import describe_validation_error

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
    """Write JSON Schemas of the job spec, job status and dataset layout (and, in a checkout, the tables of
    docs/dataset_format.md and examples/job.yaml)."""
    from onepiece_dist.cli.schema_files import refresh_format_page, render_example_job, write_schemas

    for path in write_schemas(out):
        typer.echo(str(path))
    checkout = Path(__file__).resolve().parents[2]
    page, example = checkout / "docs" / "dataset_format.md", checkout / "examples" / "job.yaml"
    if page.is_file():
        refresh_format_page(page)
        example.write_text(render_example_job())
        typer.echo(f"{page}\n{example}")


def main() -> None:
    """The ``onepiece`` command: started again with glibc's math functions pinned where it was not (sim.libm),
    so that what it simulates in process is what the workers of any node simulate."""
    restart_pinned()
    app()


if __name__ == "__main__":
    main()
