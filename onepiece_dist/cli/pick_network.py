"""`onepiece pick-labels` (pick labels of the user's objects with the user's gripper: each settled on a table, seen
by a camera, the planner's candidates executed by the pick protocol) and `onepiece pick-train` (a network fitted on
them by the shipped networks' design): the network that picks a user's objects, made as the shipped ones were
(docs/picks.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import EXIT_FAILED, EXIT_USAGE, Address, err, gripper_option, spec_mapping
from onepiece_dist.errors import OnePieceError


def _default(name: str) -> str:
    """A PickLabelSpec field's default, for --help."""
    from onepiece_dist.specs.plan import PickLabelSpec

    return f"Default: {PickLabelSpec.model_fields[name].default}."


def register(app: typer.Typer) -> None:
    app.command("pick-labels")(pick_labels)
    app.command("pick-train")(pick_train)


def pick_labels(
    objects: Annotated[str | None, typer.Option(help=f"Training objects: built-in set, folder or glob. "
                                                     f"{_default('objects')}")] = None,
    out: Annotated[Path | None, typer.Option(help=f"Folder of pick_labels.zarr. {_default('output')}")] = None,
    views: Annotated[int | None, typer.Option(help=f"Camera poses per object. {_default('views')}")] = None,
    per_view: Annotated[int | None, typer.Option(help=f"Candidates executed per view. {_default('per_view')}")
                        ] = None,
    gripper: Annotated[Path | None, typer.Option(help="A preset's name (panda | robotiq_2f85 | robotiq_2f140) or "
                                                      "a YAML gripper spec: the hand that executes the labels and "
                                                      "that the network is for. Default: the default job's box "
                                                      "gripper.")] = None,
    checkpoint: Annotated[Path | None, typer.Option(help="A network whose best-scored candidates of each view are "
                                                         "executed first (on-policy labels).")] = None,
    seed: Annotated[int | None, typer.Option(help=f"Seed of drops, cameras and executions. {_default('seed')}")
                    ] = None,
    units: Annotated[str | None, typer.Option(help=f"Units of the objects' mesh files: m, cm or mm. "
                                                   f"{_default('units')}")] = None,
    spec_file: Annotated[Path | None, typer.Option("--spec", help="YAML pick label spec (PickLabelSpec, "
                                                                  "schemas/pick_label_spec.schema.json); options "
                                                                  "given here override it.")] = None,
    address: Address = None,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run in this process without Ray.")] = False,
) -> None:
    """Pick labels of your objects for your gripper: each object settled on a table and seen by a depth camera as
    `onepiece pick` sees it, candidates planned on the view and each executed by the pick protocol (lift and shake,
    4 trials that must all hold). Labels already made by the same spec in the folder are kept and reused."""
    from onepiece_dist.picks.pick_labels import labels_made, run_pick_labels
    from onepiece_dist.specs.plan import parse_pick_label_spec
    from onepiece_dist.store.pick_labels import read_pick_labels

    given = spec_mapping(spec_file)
    given.update({k: v for k, v in {"objects": objects, "output": None if out is None else str(out), "views": views,
                                    "per_view": per_view, "seed": seed, "units": units,
                                    "checkpoint": None if checkpoint is None else str(checkpoint)}.items()
                  if v is not None})
    if gripper is not None:
        given["gripper"] = gripper_option(gripper).model_dump(mode="json")
    try:
        spec = parse_pick_label_spec(given, str(spec_file or "command line"))
        path = labels_made(spec)
        if path is not None:
            err(f"{path}: labels of this very spec are already there: kept")
        else:
            path = run_pick_labels(spec, address=address, in_process=in_process, progress=_say_object)
    except OnePieceError as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    labels = read_pick_labels(path)
    _say_labels(labels)
    if len(labels) == 0:
        raise typer.Exit(EXIT_FAILED)
    err(f"fit a network on them with:\n  onepiece pick-train {path} --out {Path(spec.output) / 'network'}")
    typer.echo(str(path))


def _say_object(labelled) -> None:
    if labelled.status != "ok":
        err(f"{labelled.name}: rejected: {labelled.reason}")
        return
    err(f"{labelled.name}: {labelled.rows} labels, {int(labelled.success.sum())} picked "
        f"({labelled.seconds:.1f} s)")


def _say_labels(labels) -> None:
    objects = labels.attrs["objects"]
    ok = sum(o["status"] == "ok" for o in objects)
    rate = float(labels.success.mean()) if len(labels) else 0.0
    err(f"{len(labels)} pick labels on {ok} of {len(objects)} objects ({rate:.0%} picked), "
        f"{labels.attrs['core_seconds']:.0f} core-seconds")
    if len(labels) == 0:
        err("error: no labels: every object was rejected or no view held a candidate (reasons above)")


def pick_train(
    labels: Annotated[Path, typer.Argument(help="The pick_labels.zarr of `onepiece pick-labels`.")],
    out: Annotated[Path, typer.Option(help="Folder for best.pt and network.json.")] = Path("onepiece-network"),
    design: Annotated[str, typer.Option(help="The network and its fit, one of the pick learning curve's "
                                             "(docs/picks.md).")] = "context_balanced",
    epochs: Annotated[int, typer.Option(min=1, help="Epochs at most (the fit stops when the validation AP has "
                                                    "not risen for 5).")] = 30,
    validation: Annotated[float, typer.Option(min=0.01, max=0.9, help="Share of the objects held out to choose "
                                                                     "the epoch and judge the network.")] = 0.1,
    seed: Annotated[int, typer.Option(help="Seed of the split, the weights and the batches.")] = 0,
    start_from: Annotated[str | None, typer.Option(help="Start the fit from this checkpoint's weights (a best.pt "
                                                         "of the same design), or from `shipped`: the network "
                                                         "shipped for the default job's gripper (81,152 labels; "
                                                         "docs/picks.md says what starting from it gives). "
                                                         "Default: fresh weights.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print network.json on stdout.")] = False,
) -> None:
    """Fit a grasp network on pick labels (by default the shipped networks' design); best.pt plans with
    `onepiece grasp --checkpoint` and is judged by `onepiece pick`."""
    from onepiece_dist.api import design_options, train_pick_network

    try:
        options = design_options(design, seed, epochs=epochs, validation=validation,
                                 start_from=_start_from(start_from))
        network = train_pick_network(labels, out, options, design)
    except (OnePieceError, ValueError) as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    best = network.result.best
    err(f"{design} fitted on {network.result.labels} labels in {network.result.seconds:.0f} s: best epoch "
        f"{best.epoch + 1} of {len(network.result.epochs)}, validation AP {best.val_ap:.2f}")
    err(network.validation.sentence())
    checkpoint = network.result.checkpoint
    err(f"judge it on objects it never saw, and plan with it:\n  onepiece pick {checkpoint} --objects HELD_OUT\n"
        f"  onepiece grasp depth.png --intrinsics k.json --camera-pose camera.json --checkpoint {checkpoint}")
    typer.echo(json.dumps(network.to_json(), indent=1) if as_json else str(checkpoint))


def _start_from(given: str | None) -> str | None:
    """The checkpoint ``--start-from`` names: the shipped default network for ``shipped``; a path must exist."""
    from onepiece_dist.plan.shipped import shipped_network

    if given is None:
        return None
    if given == "shipped":
        return str(shipped_network())
    if not Path(given).is_file():
        raise ValueError(f"--start-from {given}: no such checkpoint: give a best.pt of `onepiece pick-train` or "
                         "`shipped`")
    return given


__all__ = ["pick_labels", "pick_train", "register"]
