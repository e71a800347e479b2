"""`onepiece grasp` (grasps planned on a camera's cloud), `onepiece scene` (a depth camera's files of objects on a
simulated table) and `onepiece pick` (the simulated pick benchmark)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from onepiece_dist.cli.common import EXIT_FAILED, EXIT_USAGE, Address, err, gripper_option, spec_mapping
from onepiece_dist.errors import (
    CheckpointRejected,
    CloudRejected,
    MeshRejected,
    OnePieceError,
    SourceError,
    SpecError,
)

CARRY_HELP = ("Where no network ships for --gripper and no checkpoint is given, plan with the default job's network "
              "carried to it (its crops cut in that network's 4 x 8 x 2 cm closing region, which the gripper's must "
              "hold); what carrying picked on other hands, some below top-down: docs/picks.md.")


def _floats(text: str | None, count: int, name: str) -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        err(f"error: {name}={text!r}: give {count} comma-separated numbers")
        raise typer.Exit(EXIT_USAGE)
    return values


def register(app: typer.Typer) -> None:
    app.command()(grasp)
    app.command()(scene)
    app.command()(pick)


def scene(
    objects: Annotated[str, typer.Argument(help="The objects: built-in set, folder or glob (the first --count).")],
    out: Annotated[Path, typer.Option(help="Folder for depth.png, intrinsics.json, camera_pose.json and "
                                           "scene.json.")] = Path("onepiece-scene"),
    count: Annotated[int, typer.Option(min=1, max=8, help="Objects on the table, side by side.")] = 1,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the drops and the camera.")] = 0,
    units: Annotated[str, typer.Option(help="Units of mesh files: m, cm or mm.")] = "m",
    pile: Annotated[bool, typer.Option("--pile", help="Drop each next object onto those there (a pile), not "
                                                      "beside them.")] = False,
    depth_noise: Annotated[float, typer.Option(min=0.0, max=0.05, help="Gaussian depth noise (m) on every "
                                                                      "pixel, as a real camera's.")] = 0.0,
    flying_pixels: Annotated[float, typer.Option(min=0.0, max=1.0, help="Share of the pixels at a depth edge that "
                                                                        "mix both depths (a real camera's flying "
                                                                        "pixels).")] = 0.0,
) -> None:
    """A depth camera's own files of objects settled on a simulated table: a 16-bit depth PNG, its intrinsics and
    the camera's pose in the table's frame, to try `onepiece grasp` without a camera (docs/planning.md)."""
    from onepiece_dist.picks.scene_files import write_scene
    from onepiece_dist.specs.job import JobSpec
    from onepiece_dist.specs.plan import CameraSpec

    try:
        written = write_scene(objects, out, count, seed,
                              CameraSpec(depth_noise=depth_noise, flying_pixels=flying_pixels),
                              JobSpec(objects=objects, units=units), pile)
    except (SourceError, MeshRejected, ValueError) as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    err(f"{' + '.join(written.objects)} on the table; plan on it with:\n  {written.grasp_command()}")
    typer.echo(str(written.folder))


def grasp(
    cloud: Annotated[Path, typer.Argument(help="Point cloud (PLY, PCD, or NPY of (N, 3) metres), or with "
                                               "--intrinsics a depth image (16-bit PNG, or NPY of (H, W)).")],
    checkpoint: Annotated[Path | None, typer.Option(help="The network (best.pt of a train stage); default: the "
                                                         "shipped network (docs/planning.md).")] = None,
    out: Annotated[Path, typer.Option(help="Folder for grasps.json and grasps.png.")] = Path("onepiece-grasps"),
    top: Annotated[int, typer.Option(help="Grasps to return.")] = 10,
    candidates: Annotated[int, typer.Option(help="Candidates sampled on the cloud.")] = 500,
    intrinsics: Annotated[str | None, typer.Option(help="fx,fy,cx,cy or a JSON file ({fx, fy, cx, cy} or a 3x3 "
                                                        "K): read CLOUD as a depth image.")] = None,
    depth_scale: Annotated[float | None, typer.Option(help="Metres per depth unit (default: 0.001 for a PNG, 1 for "
                                                           "an NPY).")] = None,
    camera_pose: Annotated[Path | None, typer.Option(help="JSON camera-to-base pose ({matrix: 4x4} or position + "
                                                          "quaternion x,y,z,w): grasps come out in the base "
                                                          "frame.")] = None,
    workspace: Annotated[str | None, typer.Option(help="xmin,ymin,zmin,xmax,ymax,zmax: crop the cloud to this box "
                                                       "(the output frame) first.")] = None,
    viewpoint: Annotated[str | None, typer.Option(help="x,y,z: the camera's position in the cloud's frame "
                                                       "(normals face it; default: a depth image's camera, "
                                                       "else unknown).")] = None,
    gripper: Annotated[Path | None, typer.Option(help="A preset's name (panda | robotiq_2f85 | robotiq_2f140) or "
                                                      "a YAML gripper spec (its fields, or preset: NAME); refused "
                                                      "unless the checkpoint was trained for it (default: the "
                                                      "checkpoint's).")] = None,
    no_plane: Annotated[bool, typer.Option("--no-plane", help="The cloud is the object alone: no support "
                                                              "plane.")] = False,
    top_down: Annotated[bool, typer.Option("--top-down/--no-top-down", help="Also propose the three top-down "
                                           "grasps across the cloud's narrow horizontal axis (docs/planning.md).")
                        ] = True,
    check: Annotated[int, typer.Option(help="Check the first N grasps in simulation on the shape the view implies "
                                       "(its points and their shadows on the table) and reorder them by how often "
                                       "they held (kept by the pick benchmark: docs/picks.md); 0: the network's "
                                       "order alone.")] = 3,
    denoise: Annotated[bool, typer.Option("--denoise/--no-denoise", help="Take a depth camera's noise out of the "
                                          "view first, where the points under the table show it "
                                          "(docs/planning.md); an exact view is left as it is.")] = True,
    drop_flying: Annotated[float, typer.Option(min=0.0, max=0.05, help="With --intrinsics: drop the depth image's "
                                               "flying pixels (those inside their neighbours' depths by this many "
                                               "metres that fit neither neighbouring surface; 0.005 is the measured "
                                               "setting: docs/planning.md); 0 keeps every pixel.")] = 0.0,
    check_shape: Annotated[str, typer.Option(help="The shape checked on: hull (the points and their shadows as one "
                                             "convex hull), carved (that hull less what the camera saw through: "
                                             "openings stay open) or mirrored (with the points' half turn about "
                                             "their axis: a symmetric object's far side).")] = "hull",
    target: Annotated[str | None, typer.Option(help="x,y,z: a point on the object to pick, in the frame of the "
                                               "plan (the robot's base with --camera-pose); only grasps on the "
                                               "object nearest it (docs/planning.md).")] = None,
    one_object: Annotated[bool, typer.Option("--one-object", help="Take the whole cloud above the table for one "
                                             "object; by default objects 1 cm or more apart are told apart, each "
                                             "with its own top-down grasps and checked shape (docs/planning.md).")
                          ] = False,
    carry: Annotated[bool, typer.Option("--carry", help=CARRY_HELP)] = False,
    table_clearance: Annotated[float | None, typer.Option(min=0.0, max=0.05, help="Height (m) every corner of the "
                                                          "open gripper keeps above the table; raise it where the "
                                                          "robot's calibration is coarser (default: the planner's, "
                                                          "measured in docs/picks.md).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the sampling.")] = 0,
    device: Annotated[str, typer.Option(help="auto, cpu or cuda.")] = "auto",
    as_json: Annotated[bool, typer.Option("--json", help="Print the plan as JSON on stdout.")] = False,
) -> None:
    """Plan grasps on a depth camera's cloud: the top grasps by the network, written as JSON and drawn as PNG."""
    from onepiece_dist.api import plan_grasps
    from onepiece_dist.plan import write_plan
    from onepiece_dist.plan.shipped import shipped_summary
    from onepiece_dist.specs.plan import PlanSpec

    view, aim = _floats(viewpoint, 3, "--viewpoint"), _floats(target, 3, "--target")
    try:
        spec = PlanSpec(candidates=candidates, top_k=top, seed=seed, device=device,
                        support_plane="none" if no_plane else "auto", top_down=top_down, check_first=check,
                        check_shape=check_shape, objects_apart=not one_object, denoise="auto" if denoise else "none",
                        drop_flying=drop_flying, target=None if aim is None else tuple(aim), carry=carry,
                        **({} if table_clearance is None else {"table_clearance": table_clearance}))
        planned = plan_grasps(cloud, checkpoint, spec, intrinsics, depth_scale, None if view is None else tuple(view),
                              camera_pose, workspace, gripper_option(gripper))
    except (OnePieceError, ValueError) as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    if checkpoint is None:
        err(shipped_summary(planned.gripper, carry))
    extra = {"checkpoint": planned.checkpoint or "shipped", "output_frame": planned.frame,
             **({"carried_from": planned.carried_from} if planned.carried_from else {})}
    json_path, png = write_plan(planned.plan, planned.observation, planned.gripper, out, extra=extra)
    if as_json:
        typer.echo(json_path.read_text())
    else:
        _print_plan(planned.plan, json_path, png)


def _print_plan(plan, json_path: Path, png: Path | None) -> None:
    for note in plan.notes:
        err(f"note: {note}")
    c = plan.counts
    err(f"{plan.source}: {c.sampled} placements, {c.collided} collided, {c.below_plane} below the "
        f"plane, {c.too_few_points} with too few points, {c.scored} scored in {plan.seconds['total']:.2f} s")
    if plan.plane is not None and plan.plane.noise > 0:
        err(f"depth noise measured under the table: {plan.plane.noise * 1000:.1f} mm, taken out (--no-denoise keeps "
            "it)")
    if "check" in plan.seconds:
        err(f"the first grasps executed in simulation on the shape the view implies and reordered by how often they "
            f"held ({plan.seconds['check']:.2f} s; --check 0: the network's order alone)")
    for o in plan.objects if len(plan.objects) > 1 else ():
        err(f"  object {o.index}: {o.points} points, centre ({o.centre[0]:+.3f}, {o.centre[1]:+.3f}, "
            f"{o.centre[2]:+.3f}) m")
    for g in plan.grasps:
        centre = g.pose[:3, 3]
        err(f"  #{g.rank}  object {g.object}  score {g.score:.3f}  palm at ({centre[0]:+.3f}, {centre[1]:+.3f}, "
            f"{centre[2]:+.3f}) m  approach ({g.pose[0, 0]:+.2f}, {g.pose[1, 0]:+.2f}, {g.pose[2, 0]:+.2f})  "
            f"{g.points} points" + ("" if g.held is None else f"  held in {g.held[0]} of {g.held[1]} checks"))
    if not plan.grasps:
        err("  no grasp: every candidate collided with the cloud or the plane, or held too few points")
    typer.echo(str(json_path))
    if png is not None:
        typer.echo(str(png))


def pick(
    checkpoint: Annotated[Path | None, typer.Argument(help="The network (best.pt of a train stage); none: the "
                                                            "network shipped for the gripper.")] = None,
    objects: Annotated[str, typer.Option(help="Held-out objects: built-in set, folder or glob.")] = (
        "pybullet:random_urdfs[500:508]"),
    out: Annotated[Path, typer.Option(help="Folder for picks.json and pictures/.")] = Path("onepiece-picks"),
    views: Annotated[int, typer.Option(help="Camera poses per object.")] = 3,
    attempts: Annotated[int, typer.Option(help="k: ranked grasps tried per view.")] = 3,
    seed: Annotated[int, typer.Option(help="Seed of drops, cameras and planning.")] = 0,
    spec_file: Annotated[Path | None, typer.Option("--spec", help="YAML pick spec (PickSpec); options given "
                                                                  "here override it.")] = None,
    clutter: Annotated[int, typer.Option(help="Objects on the table together a view: N > 1 sets each object "
                                         "with the next N-1; a grasp picks the one it closes on (docs/picks.md).")
                       ] = 1,
    pile: Annotated[bool, typer.Option("--pile", help="With --clutter N: each next object dropped onto those "
                                                      "there (a pile), not beside them.")] = False,
    gripper: Annotated[Path | None, typer.Option(help="A preset's name (panda | robotiq_2f85 | robotiq_2f140) or "
                                                      "a YAML gripper spec that executes the picks; "
                                                      "refused unless the checkpoint was trained for it (default: "
                                                      "the checkpoint's; without one, the network shipped for "
                                                      "it).")] = None,
    units: Annotated[str | None, typer.Option(help="Units of the objects' mesh files: m, cm or mm (default: m).")
                     ] = None,
    carry: Annotated[bool, typer.Option("--carry", help=CARRY_HELP)] = False,
    address: Address = None,
    in_process: Annotated[bool, typer.Option("--in-process", help="Run in this process without Ray.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON on stdout.")] = False,
) -> None:
    """The simulated pick benchmark: objects settled on a table, one depth camera, the planner's best grasp executed
    with the label protocol; first-attempt and within-k pick success beside the baselines and the oracle."""
    from onepiece_dist.api import run_picks
    from onepiece_dist.plan.shipped import shipped_summary
    from onepiece_dist.specs.plan import parse_pick_spec

    given = spec_mapping(spec_file)
    given.update({**({"checkpoint": str(checkpoint)} if checkpoint is not None else {}), "objects": objects,
                  "output": str(out), "views": views,
                  "attempts": attempts, "seed": seed, **({"clutter": clutter} if clutter != 1 else {}),
                  **({"pile": True} if pile else {}), **({"units": units} if units is not None else {}),
                  **({"gripper": gripper_option(gripper).model_dump(mode="json")} if gripper is not None else {})})
    if carry:
        given["plan"] = {**given.get("plan", {}), "carry": True}
    try:
        spec = parse_pick_spec(given, str(spec_file or "command line"))
        if spec.checkpoint is None:
            err(shipped_summary(spec.gripper, spec.plan.carry).replace("planning with", "picking with", 1))
        report = run_picks(spec, address=address, in_process=in_process,
                           progress=lambda o: err(f"{o.name}: {o.status} {o.reason}".rstrip()))
    except (SpecError, SourceError, CloudRejected, CheckpointRejected) as error:
        err(f"error: {error}")
        raise typer.Exit(EXIT_USAGE) from None
    loaded = any(o.status == "ok" for o in report.objects)
    if as_json:
        typer.echo(json.dumps(report.to_json()))
        if not loaded:
            raise typer.Exit(EXIT_FAILED)
        return
    for m in report.methods:
        err(f"{m.method:<18} first attempt {m.first_attempt:.0%} [{m.first_attempt_interval[0]:.0%}, "
            f"{m.first_attempt_interval[1]:.0%}]  within {spec.attempts}: {m.within_k:.0%}  ({m.views} views)")
    err(report.verdict)
    typer.echo(str(Path(spec.output) / "picks.json"))
    if not loaded:  # every object rejected (the reasons above): nothing was picked
        raise typer.Exit(EXIT_FAILED)
