"""The network shipped with the package (issue 56): ``onepiece grasp`` plans with it when no checkpoint is given.
It and its record (how it was trained, what it picks) are package data in ``plan/networks/``, made by the committed
command ``python -m benchmarks.experiments.ship_network`` (docs/picks.md)."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.errors import CloudRejected

FOLDER = Path(__file__).resolve().parent / "networks"
NETWORK = FOLDER / "pick_view.pt"
RECORD = FOLDER / "pick_view.json"


def shipped_network() -> Path:
    """The shipped checkpoint's path; :class:`CloudRejected` with the fix when this install lacks it."""
    if not NETWORK.is_file():
        raise CloudRejected(f"{NETWORK}: the shipped network is missing from this install: give --checkpoint "
                            "(a best.pt), or reinstall the package")
    return NETWORK


def shipped_record() -> dict:
    """What the shipped network is: its training and its pick figures ({} when the record is missing)."""
    return json.loads(RECORD.read_text()) if RECORD.is_file() else {}


def shipped_summary() -> str:
    """One line for the user: which network plans and what it picks."""
    record = shipped_record()
    if not record:
        return f"planning with the shipped network {NETWORK.name}"
    picks, unseen = record["household_first_attempt"], record.get("unseen_first_attempt")
    views = f"{picks['views']} " if picks.get("views") else ""
    also = (f", {_rate(unseen)} of {unseen['views']} views of household objects it was never chosen on"
            if unseen else "")
    return (f"planning with the shipped network {NETWORK.name} ({record['design']}, {record['labels']} pick labels "
            f"on {record['training_objects']}): it picks {_rate(picks)} of {views}household views at the first "
            f"attempt in simulation{also} (docs/picks.md)")


def _rate(figure: dict) -> str:
    low, high = figure["interval"]
    return f"{100 * figure['rate']:.0f}% [{100 * low:.0f}%, {100 * high:.0f}%]"
