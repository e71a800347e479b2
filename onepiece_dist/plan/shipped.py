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
    picks = record["household_first_attempt"]
    views = f"{picks['views']} " if picks.get("views") else ""
    return (f"planning with the shipped network {NETWORK.name} ({record['design']}, {record['labels']} pick labels "
            f"on {record['training_objects']}): it picks {100 * picks['rate']:.0f}% "
            f"[{100 * picks['interval'][0]:.0f}%, {100 * picks['interval'][1]:.0f}%] of {views}household "
            f"views at the first attempt in simulation (docs/picks.md)")
