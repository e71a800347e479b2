"""`onepiece label --grasps FILE`: grasps made elsewhere (ACRONYM .h5, GraspGen .json), labelled by our protocol on
their meshes, written as our dataset, with how often our label agrees with theirs (job.relabel)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import Address, build_spec, err, exit_codes


def label(
    grasps: Annotated[list[Path], typer.Option("--grasps", help="An ACRONYM .h5 or GraspGen .json grasp file, "
                                               "in grasps/ beside its meshes' folder (repeat for more).")],
    out: Annotated[Path, typer.Option(help="Dataset path (Zarr directory).")],
    spec_file: Annotated[Path | None, typer.Option("--spec", help="A job spec for everything else (sim, views, "
                                                   "seed); its sim settings replace the default protocol.")] = None,
    gripper: Annotated[str | None, typer.Option(help="A gripper preset (default: the one the files name).")] = None,
    report: Annotated[Path | None, typer.Option(help="Where the agreement report goes (JSON; default: "
                                                "OUT.relabel.json).")] = None,
    address: Address = None,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run in this process without Ray.")] = False,
) -> None:
    """Label a grasp file's grasps by our protocol (4 trials that must all hold, unless --spec says otherwise) and
    print how often our label agrees with theirs."""
    from onepiece_dist.api import relabel_report, relabel_spec, resolve_source, run_job

    with exit_codes():
        base = build_spec(spec_file, {}) if spec_file is not None else None
        spec = relabel_spec(list(grasps), out, gripper, base)
        status = run_job(spec, address=address, in_process=in_process)
        result = relabel_report(out, resolve_source(spec.objects))
    path = report or Path(f"{out}.relabel.json")
    path.write_text(result.to_json())
    for rejection in status.rejections:
        err(f"rejected {rejection.name}: {rejection.reason}")
    for row in result.files:
        err(f"{row.name}: {_line(row.table)}")
    err(f"all {result.overall.grasps} grasps ({result.protocol}): {_line(result.overall)}")
    typer.echo(str(path))


def _line(table) -> str:
    pct = lambda x: "n/a" if math.isnan(x) else f"{100 * x:.0f}%"  # noqa: E731
    return (f"agreement {pct(table.agreement)} (kappa {table.kappa:.2f}); theirs {pct(table.their_positive_rate)} "
            f"held, ours {pct(table.our_positive_rate)}; of theirs that held, {pct(table.ours_given_theirs)} hold for "
            f"us; of ours, {pct(table.theirs_given_ours)} held for them")


def register(app: typer.Typer) -> None:
    app.command()(label)
