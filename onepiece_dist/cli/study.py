"""`onepiece study run|report`: does ONE PIECE pay on *your* objects, and what is the cheapest plan? A study's
jobs run on the embedded Ray (127.0.0.1) or the cluster at --address; its result goes to --out (docs/study.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import EXIT_USAGE, Address, err, exit_codes

study_app = typer.Typer(add_completion=False, no_args_is_help=True,
                        help="A study: arms A, B and R on your train objects, scored on held-out objects.")
AsJson = Annotated[bool, typer.Option("--json", help="Print the result as JSON on stdout.")]


@study_app.command("run")
def run(
    study_file: Annotated[Path | None, typer.Argument(metavar="[STUDY]", help="YAML or JSON study spec "
                                                      "(examples/studies/).")] = None,
    train: Annotated[str | None, typer.Option(help="Train objects: a folder, a glob or a pybullet set.")] = None,
    heldout: Annotated[str | None, typer.Option(help="Held-out objects, never trained on (same forms).")] = None,
    out: Annotated[Path, typer.Option(help="The study's folder: study.json, study.md, its jobs and runs.")] = Path(
        "onepiece-study"),
    quick: Annotated[bool, typer.Option("--quick", help="Small sizes (24 candidates, 2 label trials, a short "
                                                        "voxel training): minutes, not hours.")] = False,
    address: Address = None,
    workers: Annotated[int | None, typer.Option(help="Workers per job (default: the cluster's CPUs).")] = None,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run without Ray (debugging).")] = False,
    extend: Annotated[bool, typer.Option("--extend", help="Take over --out's study when this one differs from it "
                                         "only in its arms or targets (radii, static_radii, budgets, adaptive, "
                                         "keys, targets): its jobs and runs are reused, its result replaced.")
                      ] = False,
    judge: Annotated[str | None, typer.Option(help="candidates, picks or both: what decides (default: the "
                                              "study's, candidates).")] = None,
    as_json: AsJson = False,
) -> None:
    """Run a study (or finish one cut short: every finished job and training run is reused) and print the path of
    its page."""
    from onepiece_dist.study.runner import Where, run_study
    from onepiece_dist.study.spec import load_study_spec

    if address and address.startswith(("http://", "https://")):
        err(f"error: a study drives its jobs from here and needs a Ray address ('auto' or host:port), not the Jobs "
            f"API URL {address}")
        raise typer.Exit(EXIT_USAGE)
    with exit_codes(address):
        spec = load_study_spec(study_file, {"train": train, "heldout": heldout, "judge": judge}, quick=quick)
        result = run_study(spec, out, Where(address=address, in_process=in_process, workers=workers), say=err,
                           extend=extend)
    _show(result, out, as_json)


@study_app.command("report")
def report(
    folder: Annotated[Path, typer.Argument(help="A study's folder (its study.json).")],
    as_json: AsJson = False,
) -> None:
    """Render a study's page again from its study.json."""
    from onepiece_dist.study.runner import report_study

    with exit_codes():
        result = report_study(folder)
    _show(result, folder, as_json)


def _show(result, folder: Path, as_json: bool) -> None:
    from onepiece_dist.study.page import picks_lines, verdict

    for line in picks_lines(result) + verdict(result):
        err(line.replace("**", ""))
    typer.echo(result.model_dump_json(indent=2) if as_json else str(folder / "study.md"))
