"""The networks shipped with the package (issue 56): ``onepiece grasp`` plans with the one trained for its gripper
when no checkpoint is given: the default job's box gripper's (``pick_view.pt``), the Franka hand's for the
``panda`` preset (``pick_view_panda.pt``, issue 55), or the Robotiq 2F-85's and 2F-140's for their presets
(``pick_view_robotiq_2f85.pt``, ``pick_view_robotiq_2f140.pt``: made by ``onepiece pick-labels`` and ``onepiece
pick-train`` with their defaults).
Each and its record (how it was trained, what it picks) are package data in ``plan/networks/``, made by the
committed command ``python -m benchmarks.experiments.ship_network`` (docs/picks.md).

A hand none ships for is refused; asked to (``PlanSpec.carry``, ``--carry``), where its closing region holds the
default job's gripper's (the box every crop is cut in: 4 x 8 x 2 cm), it is planned for by the default job's network
carried to it (``planning_network``): its crops cut in that network's own region, so that it sees the shapes it was
trained on, and its grasps proposed, checked and executed by that hand. Carrying is asked for, not assumed: carried
to the Franka Panda read from its URDF it picks less than top-down. What it picks carried to the preset hands,
beside their own networks and top-down, and to that URDF hand, is ``carried.json``, made by ``python -m
benchmarks.experiments.pick_carried`` (docs/picks.md). A hand whose region is smaller in any extent is refused even
so: the network would judge points its fingers cannot reach."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from onepiece_dist.errors import CheckpointRejected, CloudRejected
from onepiece_dist.plan.scorer import REGION
from onepiece_dist.specs.job import GripperSpec

FOLDER = Path(__file__).resolve().parent / "networks"
SHIPPED = {"onepiece_box": "pick_view", "franka_panda": "pick_view_panda",  # gripper name -> the files' stem
           "robotiq_2f_85": "pick_view_robotiq_2f85", "robotiq_2f_140": "pick_view_robotiq_2f140"}
NETWORK = FOLDER / f"{SHIPPED[GripperSpec().name]}.pt"  # the default job's gripper's
RECORD = NETWORK.with_suffix(".json")
CARRIED = FOLDER / "carried.json"  # what the default job's network picks carried to the preset hands
SHIP_FOR = f"networks ship for {', '.join(SHIPPED)} (gripper presets panda, robotiq_2f85, robotiq_2f140)"
MAKE_ONE = ("make one for this gripper (onepiece pick-labels --gripper ... --out labels/, then onepiece pick-train "
            "labels/pick_labels.zarr) and give --checkpoint")


@dataclass(frozen=True)
class PlanningNetwork:
    """The network that plans for a gripper where no checkpoint is given: its ``path``, and ``carried_from``, the
    gripper it was trained for where it is carried to another hand (None: trained for this one)."""

    path: Path
    carried_from: str | None = None

    @property
    def carried(self) -> bool:
        return self.carried_from is not None


def planning_network(gripper: GripperSpec | None = None, carry: bool = False) -> PlanningNetwork:
    """The network shipped for ``gripper``; where none ships for it and ``carry`` (PlanSpec.carry) allows it, the
    default job's carried to it when its closing region holds that network's (:class:`CheckpointRejected` naming
    the fix where it does not)."""
    gripper = gripper or GripperSpec()
    if gripper.name in SHIPPED:
        return PlanningNetwork(shipped_network(gripper))
    if not carry:
        raise CheckpointRejected(f"no network ships for the gripper {gripper.name!r}: {SHIP_FOR}; {MAKE_ONE}, or plan "
                                 f"with the default job's network carried to it (--carry: {carried_figures()})")
    default = GripperSpec()
    smaller = [name for name in REGION if getattr(gripper, name) < getattr(default, name) - 1e-12]
    if smaller:
        raise CheckpointRejected(
            f"no network ships for the gripper {gripper.name!r}, and the default job's network is carried only to "
            f"a hand whose closing region holds its own ({', '.join(f'{n}={getattr(default, n)}' for n in REGION)} "
            f"m; this hand's {', '.join(f'{n}={getattr(gripper, n)}' for n in smaller)}): {SHIP_FOR}; {MAKE_ONE}")
    return PlanningNetwork(shipped_network(), default.name)


def network_path(gripper: GripperSpec | None = None) -> Path:
    """Where the network shipped for ``gripper`` (None: the default job's) lies; :class:`CheckpointRejected`
    naming the grippers networks ship for where none ships for this one."""
    name = (gripper or GripperSpec()).name
    if name not in SHIPPED:
        raise CheckpointRejected(f"no network ships for the gripper {name!r}: {SHIP_FOR}; {MAKE_ONE}")
    return FOLDER / f"{SHIPPED[name]}.pt"


def shipped_network(gripper: GripperSpec | None = None) -> Path:
    """The checkpoint shipped for ``gripper`` (network_path); :class:`CloudRejected` with the fix when this install
    lacks it."""
    path = network_path(gripper)
    if not path.is_file():
        raise CloudRejected(f"{path}: the shipped network is missing from this install: give --checkpoint "
                            "(a best.pt), or reinstall the package")
    return path


def shipped_record(gripper: GripperSpec | None = None) -> dict:
    """What the network shipped for ``gripper`` is: its training and its pick figures ({} when the record is
    missing)."""
    record = network_path(gripper).with_suffix(".json")
    return json.loads(record.read_text()) if record.is_file() else {}


def shipped_summary(gripper: GripperSpec | None = None, carry: bool = False) -> str:
    """One line for the user: which network plans for ``gripper`` (``carry``: PlanSpec.carry) and what it picks."""
    if gripper is not None and planning_network(gripper, carry).carried:
        return carried_summary(gripper)
    record, name = shipped_record(gripper), network_path(gripper).name
    if not record:
        return f"planning with the shipped network {name}"
    picks, unseen = record["household_first_attempt"], record.get("unseen_first_attempt")
    views = f"{picks['views']} " if picks.get("views") else ""
    hand = f", executed by the {record['gripper']} gripper" if record.get("gripper") else ""
    also = (f", {_rate(unseen)} of {unseen['views']} views of household objects it was never chosen on"
            if unseen else "")
    return (f"planning with the shipped network {name} ({record['design']}, {record['labels']} pick labels "
            f"on {record['training_objects']}): it picks {_rate(picks)} of {views}household views at the first "
            f"attempt in simulation{hand}{also} (docs/picks.md)")


def _rate(figure: dict) -> str:
    low, high = figure["interval"]
    return f"{100 * figure['rate']:.0f}% [{100 * low:.0f}%, {100 * high:.0f}%]"


def carried_summary(gripper: GripperSpec) -> str:
    """One line for the user: the default job's network carried to ``gripper``, and what carrying picked."""
    return (f"no network ships for the gripper {gripper.name!r}: planning with the default job's network "
            f"{NETWORK.name} carried to it (its crops cut in that network's closing region, which this hand's holds; "
            f"{carried_figures()}); or {MAKE_ONE}")


def carried_figures() -> str:
    """What the default job's network picked carried to each hand measured (carried.json), against that hand's
    own network where one ships, else against top-down."""
    if not CARRIED.is_file():
        return "docs/picks.md"
    hands = json.loads(CARRIED.read_text())["hands"]
    against = ", ".join(f"{h['gripper']} {_percent(h['carried'])} against " + (
        f"its own network {_percent(h['own'])}" if h["own"] else f"top-down {_percent(h['top_down'])}") for h in hands)
    return (f"carried to other hands it picked, at the first attempt on {hands[0]['carried']['views']} views of "
            f"household objects in simulation, {against}: docs/picks.md")


def _percent(figure: dict) -> str:
    return f"{100 * figure['rate']:.0f}%"
