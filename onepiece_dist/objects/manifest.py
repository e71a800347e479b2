"""``objects.yaml`` beside a folder of objects: their units and, per object, what a mesh file does not say.

    units: cm                  # m, cm or mm: the folder's files (a job's units then do not apply to them)
    objects:
      mug.obj: {scale: 0.9, mass: 0.3, friction: 0.8}
      bowl.obj: {density: 500}

Per object: ``scale`` (after units), ``mass`` (kg) or ``density`` (kg/m^3) instead of the job's sim.density, and
``friction``, the object's coefficient (Bullet multiplies it with the finger pads'; 1 leaves the pads' alone).
Names are file paths relative to the folder. A name no file has, or a field the manifest does not know, is refused
with the manifest's path and the fix.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from onepiece_dist.errors import SourceError

MANIFEST = "objects.yaml"
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
FIELDS = ("scale", "mass", "density", "friction")


@dataclass(frozen=True)
class ObjectSettings:
    """One object's settings from a manifest; None: the job's."""

    scale: float = 1.0
    mass: float | None = None
    density: float | None = None
    friction: float | None = None


@dataclass(frozen=True)
class Manifest:
    """A folder's manifest: its units' scale (None when it names none) and each named object's settings."""

    unit_scale: float | None
    objects: dict[str, ObjectSettings]


def read_manifest(folder: Path) -> Manifest | None:
    """The manifest of ``folder``, or None when it has none."""
    import yaml

    path = folder / MANIFEST
    if not path.is_file():
        return None
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as err:
        raise SourceError(f"{path}: not readable YAML: {err}") from None
    if not isinstance(data, dict) or set(data) - {"units", "objects"}:
        raise SourceError(f"{path}: a manifest holds 'units' and 'objects' only, got {sorted(data)}")
    units = data.get("units")
    if units is not None and units not in UNITS:
        raise SourceError(f"{path}: units={units!r}: give m, cm or mm")
    objects = {str(name): _settings(path, str(name), fields) for name, fields in (data.get("objects") or {}).items()}
    for name in objects:
        if not (folder / name).is_file():
            raise SourceError(f"{path}: names {name!r}, which is not a file of {folder} (names are paths relative "
                              "to the folder)")
    return Manifest(UNITS[units] if units else None, objects)


def _settings(path: Path, name: str, fields) -> ObjectSettings:
    if not isinstance(fields, dict) or set(fields) - set(FIELDS):
        raise SourceError(f"{path}: objects.{name}: give a mapping of {', '.join(FIELDS)}, got {fields!r}")
    if "mass" in fields and "density" in fields:
        raise SourceError(f"{path}: objects.{name}: give mass or density, not both")
    for field, value in fields.items():
        if not isinstance(value, int | float) or isinstance(value, bool) or value <= 0:
            raise SourceError(f"{path}: objects.{name}.{field}={value!r}: a positive number")
    return ObjectSettings(**{k: float(v) for k, v in fields.items()})
