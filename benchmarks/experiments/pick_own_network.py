"""A network made by the two commands a user runs (issue 55): `onepiece pick-labels` with its defaults (8 views
each, 16 candidates executed a view, the default job's box gripper) on FIRST_OBJECTS (its first default objects) and
`onepiece pick-train` with its defaults (the shipped design), at several label seeds and fit seeds; each network
judged by `onepiece pick` on the household and unseen sets (8 views an object, the planner's defaults: its first 3
grasps checked), the network chooser alone, beside the shipped network on the same views.

    .venv/bin/python -m benchmarks.experiments.pick_own_network [--label-seeds 0,1] [--fit-seeds 0,1]
        [--gripper panda] [--objects SOURCE] [--start-from shipped] [--label-clearance M] [--again]

With ``--gripper panda`` the Franka hand labels and picks, beside the network shipped for it; with ``--gripper
panda_urdf`` the Franka Panda read from pybullet_data's URDF (none ships for it: each network is judged beside random
and top-down, as for any hand none ships for); ``--objects`` labels
other objects (pick-labels' default today; more of them: more labels); ``--start-from shipped`` starts each fit
from the network shipped for the default job's gripper (`onepiece pick-train --start-from shipped`);
``--label-clearance`` plans the labels' candidates with the open gripper that high over the table (default: the
planner's today, 8 mm; every row before it was recorded was labelled at 2 mm, the planner's then); ``--again``
judges every network already judged again with today's planner (its labels and fit kept). Labels:
data/own_network[_panda]/labels_[gap8mm_]s<L>/ (kept where they hold labels of the same spec); networks:
data/own_network[_panda]/net_l<L>_f<F>/best.pt; results: benchmarks/results/pick_own_network[_panda].json (written
as each network lands; a run again judges only what is not in it), rendered on docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from datetime import date
from pathlib import Path

from onepiece_dist.specs.plan import PLANNER_CLEARANCE_BEFORE, PlanSpec

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
VIEWS = 8
SETS = ("household", "unseen")
READ_FROM_URDF = {"panda_urdf": ("franka_panda", "panda.urdf")}  # --gripper names of hands read from pybullet_data
FIRST_OBJECTS = "pybullet:random_urdfs[0:64]"  # pick-labels' default objects when this experiment began


def named(gripper: str | None) -> str:
    return "own_network" + ("" if gripper is None else f"_{gripper}")


def given(gripper: str | None) -> str | dict | None:
    """What a spec's ``gripper`` field takes for the ``--gripper`` name: a preset's name as it is, a hand read from
    a URDF (READ_FROM_URDF) as ``{"urdf": PATH}``."""
    if gripper not in READ_FROM_URDF:
        return gripper
    import pybullet_data

    return {"urdf": str(Path(pybullet_data.getDataPath()).joinpath(*READ_FROM_URDF[gripper]))}


def tag(objects: str | None) -> str:
    """The folders' prefix for labels of ``objects`` (none for the default's)."""
    return "" if objects is None else "".join(c if c.isalnum() else "_" for c in objects).strip("_") + "_"


def height_tag(clearance: float) -> str:
    """The folders' prefix for labels whose candidates kept the open gripper ``clearance`` (m) over the table (none
    for the 2 mm of the planner before PlanSpec.table_clearance: every folder labelled then)."""
    return "" if clearance == PLANNER_CLEARANCE_BEFORE else f"gap{1000 * clearance:g}mm_"


def net_prefix(objects: str | None, start_from: str | None, clearance: float = PLANNER_CLEARANCE_BEFORE) -> str:
    """The networks' folder prefix for labels of ``objects`` made ``clearance`` over the table, fitted from
    ``start_from`` (None: fresh weights)."""
    return ("from_shipped_" if start_from else "") + height_tag(clearance) + tag(objects)


def label_height(entry: dict) -> float:
    """The height (m) over the table the candidates of a network's labels kept (rows made before it was recorded:
    the planner's 2 mm then)."""
    return entry["made"].get("table_clearance", PLANNER_CLEARANCE_BEFORE)


def net_name(prefix: str, label_seed: int, fit_seed: int) -> str:
    """The folder (under data/own_network[_gripper]/) of the fit at ``fit_seed`` on ``label_seed``'s labels."""
    return f"net_{prefix}l{label_seed}_f{fit_seed}"


def labels(seed: int, gripper: str | None, objects: str | None = None,
           clearance: float = PLANNER_CLEARANCE_BEFORE) -> tuple[Path, dict]:
    """The default pick labels at ``seed`` with ``gripper`` (a preset; None: the default job's) of ``objects``
    (None: FIRST_OBJECTS), their candidates planned ``clearance`` over the table, made unless kept, and what making
    them cost."""
    from onepiece_dist.picks.pick_labels import labels_made, run_pick_labels
    from onepiece_dist.specs.plan import PickLabelSpec
    from onepiece_dist.store.pick_labels import read_pick_labels

    folder = ROOT / "data" / named(gripper) / f"labels_{height_tag(clearance)}{tag(objects)}s{seed}"
    spec = PickLabelSpec(output=str(folder), seed=seed, objects=objects or FIRST_OBJECTS,
                         plan=PlanSpec(table_clearance=clearance), **({"gripper": given(gripper)} if gripper else {}))
    path = labels_made(spec) or run_pick_labels(spec)
    made = read_pick_labels(path)
    return path, {"seed": seed, "objects": spec.objects, "views": spec.views, "per_view": spec.per_view,
                  "table_clearance": clearance, "gripper": spec.gripper.name, "labels": len(made),
                  **({"urdf": "/".join(READ_FROM_URDF[gripper])} if gripper in READ_FROM_URDF else {}),
                  "success_rate": round(float(made.success.mean()), 4),
                  "core_seconds": made.attrs["core_seconds"], "wall_seconds": made.attrs["wall_seconds"]}


def network(path: Path, label_seed: int, fit_seed: int, prefix: str = "", start_from: str | None = None) -> dict:
    """The shipped design fitted on the labels at ``path`` (`onepiece pick-train`), from fresh weights or, with
    ``start_from`` "shipped", from the network shipped for the default job's gripper (`--start-from shipped`)."""
    from onepiece_dist.learn.pick_network import SHIPPED_DESIGN, design_options, train_pick_network
    from onepiece_dist.plan.shipped import shipped_network

    start = None if start_from is None else str(shipped_network())
    network = train_pick_network(path, path.parent.parent / net_name(prefix, label_seed, fit_seed),
                                 design_options(SHIPPED_DESIGN, fit_seed, start_from=start))
    started = {} if start is None else {"start_from": str(Path(start).relative_to(ROOT))}
    return {**network.to_json(), **started, "checkpoint": str(network.result.checkpoint.relative_to(ROOT)),
            "labels": str(path.relative_to(ROOT)), "fit_seconds": round(network.result.seconds, 1)}


def judged(checkpoint: Path | None, name: str, gripper: str | None, others: tuple[str, ...] = (), plan=None,
           folder: Path | None = None, carried: bool = False) -> dict:
    """``checkpoint`` (None: the network shipped for ``gripper``) on each of SETS, executed by ``gripper``, as
    `onepiece pick` judges it (with ``plan``, a PlanSpec, where given; ``carried``: a checkpoint trained for another
    gripper, carried to this one); with ``others`` (pick methods: random, top_down) judged on the same views too.
    Its picks are written under ``folder`` (default: this experiment's)."""
    from benchmarks.experiments.picks import sets
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import PickSpec

    out, folder = {}, folder or ROOT / "data" / named(gripper) / "picks" / name
    for set_name in SETS:
        spec = PickSpec(objects=sets()[set_name][0](), checkpoint=None if checkpoint is None else str(checkpoint),
                        output=str(folder / set_name), views=VIEWS, methods=("network", *others), pictures=0,
                        gripper=hand(gripper), carried=carried, **({} if plan is None else {"plan": plan}))
        start = time.perf_counter()
        report = run_picks(spec)
        figures = {m.method: {"first_attempt": m.first_attempt, "interval": list(m.first_attempt_interval),
                              "views": m.views, "per_object": report.first_picks(m.method)} for m in report.methods}
        out[set_name] = {**figures["network"], "seconds": round(time.perf_counter() - start, 1),
                         **({"others": {m: figures[m] for m in others}} if others else {})}
    return out


def hand(gripper: str | dict | None):
    """The GripperSpec of the preset ``gripper`` (or a READ_FROM_URDF name, or fields, or ``{"urdf": PATH}``; None:
    the default job's)."""
    from onepiece_dist.gripper.presets import gripper_fields
    from onepiece_dist.specs.job import GripperSpec

    gripper = given(gripper) if isinstance(gripper, str) else gripper
    return GripperSpec.model_validate(gripper_fields(gripper)) if gripper else GripperSpec()


def ships_for(gripper: str | None) -> bool:
    """Whether a network ships for ``gripper`` (else each network is judged beside random and top-down)."""
    from onepiece_dist.plan.shipped import SHIPPED

    return hand(gripper).name in SHIPPED


def judge_again(result: dict, gripper: str | None, others: tuple[str, ...], write: Callable[[], None]) -> None:
    """Every network of ``result`` (and the shipped one where it was judged) judged again as `onepiece pick`
    judges today (the planner's defaults), its labels and fit kept: the rows stay comparable with each other."""
    if result["shipped"] is not None:
        result["shipped"] = judged(None, "shipped", gripper)
        write()
    for entry in result["networks"]:
        checkpoint = ROOT / entry["network"]["checkpoint"]
        if not checkpoint.is_file():
            raise SystemExit(f"{checkpoint}: not here; run without --again to make it (its labels and fit)")
        entry["picks"] = judged(checkpoint, checkpoint.parent.name.removeprefix("net_"), gripper, others)
        write()
        print(checkpoint.parent.name, {k: v["first_attempt"] for k, v in entry["picks"].items()}, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label-seeds", default="0,1")
    parser.add_argument("--fit-seeds", default="0,1")
    parser.add_argument("--gripper", default=None,
                        help="a gripper preset (panda, robotiq_2f85, ...) or panda_urdf (the Franka Panda read from "
                             "pybullet_data's URDF); default: the default job's")
    parser.add_argument("--objects", default=None, help=f"pick-labels --objects (default: {FIRST_OBJECTS})")
    parser.add_argument("--start-from", default=None, choices=("shipped",),
                        help="pick-train --start-from shipped: each fit starts from the default job's shipped network")
    parser.add_argument("--label-clearance", type=float, default=PlanSpec().table_clearance,
                        help="m the labels' candidates keep the open gripper over the table (default: the planner's "
                             f"today; {PLANNER_CLEARANCE_BEFORE} before PlanSpec.table_clearance existed)")
    parser.add_argument("--again", action="store_true",
                        help="judge every network already judged again with today's planner (labels and fits kept)")
    args = parser.parse_args()
    path = HERE / "results" / f"pick_{named(args.gripper)}.json"
    result = json.loads(path.read_text()) if path.is_file() else {"networks": [], "shipped": None}
    result.update({"command": ".venv/bin/python -m benchmarks.experiments.pick_own_network"
                              + (f" --gripper {args.gripper}" if args.gripper else ""),
                   "date": date.today().isoformat(), "views": VIEWS,
                   "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}"})

    def write() -> None:
        path.write_text(json.dumps(result, indent=1) + "\n")

    judged_beside = result["shipped"] is None and bool(result["networks"])  # its rows stay comparable
    others = ("random", "top_down") if judged_beside or not ships_for(args.gripper) else ()
    if args.again:
        return judge_again(result, args.gripper, others, write)
    if result["shipped"] is None and not others:
        result["shipped"] = judged(None, "shipped", args.gripper)
        write()
    done = {(n["made"]["objects"], label_height(n), n.get("start_from"), n["label_seed"], n["fit_seed"])
            for n in result["networks"]}
    for label_seed in (int(s) for s in args.label_seeds.split(",")):
        labelled, made = labels(label_seed, args.gripper, args.objects, args.label_clearance)
        for fit_seed in (int(s) for s in args.fit_seeds.split(",")):
            if (made["objects"], args.label_clearance, args.start_from, label_seed, fit_seed) in done:
                continue
            prefix = net_prefix(args.objects, args.start_from, args.label_clearance)
            fitted = network(labelled, label_seed, fit_seed, prefix, args.start_from)
            entry = {"label_seed": label_seed, "fit_seed": fit_seed, "made": made, "network": fitted,
                     **({"start_from": args.start_from} if args.start_from else {}),
                     "picks": judged(ROOT / fitted["checkpoint"], f"{prefix}l{label_seed}_f{fit_seed}", args.gripper,
                                     others)}
            result["networks"] = sorted([*result["networks"], entry], key=lambda n: (
                n["made"]["labels"], label_height(n), n.get("start_from") or "", n["label_seed"], n["fit_seed"]))
            write()
            print(label_seed, fit_seed, {k: v["first_attempt"] for k, v in entry["picks"].items()}, flush=True)
    print(path)


if __name__ == "__main__":
    main()
