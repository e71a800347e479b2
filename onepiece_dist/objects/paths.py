"""Path confinement: input paths never escape their root."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path, PurePosixPath

from onepiece_dist.errors import PathEscape

_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")
PACKAGE_MAP = "onepiece_packages.json"  # in an input root: {"ros_package_name": "folder/inside/the/root", ...}
PACKAGE_MAP_BYTES = 65536


def confined(path: str | os.PathLike, root: str | os.PathLike, source: str) -> Path:
    """Real path of ``path`` if it lies inside ``root`` (symlinks followed), else :class:`PathEscape`."""
    real_root = os.path.realpath(root)
    real = os.path.realpath(path)
    if os.path.commonpath([real_root, real]) != real_root:
        raise PathEscape(source, f"path {os.fspath(path)!r} resolves to {real!r}, outside its root {real_root!r}")
    return Path(real)


def package_reference(reference: str, root: Path, source: str) -> Path:
    """Resolve ``package://NAME/rest`` (ROS URDFs) through the package map file of the input ``root``
    (PACKAGE_MAP, never the environment): NAME's folder, relative to the root, then ``rest``, confined to it."""
    name, _, rest = reference[len("package://"):].partition("/")
    packages = _package_map(root, source)
    if name not in packages:
        raise PathEscape(source, f"mesh path {reference!r} names package {name!r}, which {PACKAGE_MAP} in "
                                 f"{os.fspath(root)!r} does not map (mapped: {sorted(packages)})")
    folder = relative_reference(packages[name], root, source, what=f"{PACKAGE_MAP} entry {name!r}")
    return relative_reference(rest, folder, source)


def package_folders(root: Path) -> dict[str, str]:
    """The package map of an input root, or {} when it has none or it cannot be used (judged at load time)."""
    try:
        return _package_map(root, str(root))
    except PathEscape:
        return {}


def _package_map(root: Path, source: str) -> dict[str, str]:
    path = Path(root) / PACKAGE_MAP
    if not path.is_file():
        return {}
    real = confined(path, root, source)
    if real.stat().st_size > PACKAGE_MAP_BYTES:
        raise PathEscape(source, f"{real}: larger than {PACKAGE_MAP_BYTES} bytes")
    try:
        packages = json.loads(real.read_text())
    except ValueError as err:
        raise PathEscape(source, f"{real}: not valid JSON ({err})") from None
    if not isinstance(packages, dict) or not all(isinstance(v, str) for v in packages.values()):
        raise PathEscape(source, f"{real}: must map package names to folder paths (strings)")
    return packages


def relative_reference(reference: str, base_dir: Path, source: str, what: str = "mesh path") -> Path:
    """Resolve a file name written inside a file (a URDF mesh) strictly under that file's folder.

    Absolute paths, URL schemes (file://, package://, http://), '..' components and symlinks that leave
    ``base_dir`` are refused.
    """
    if _SCHEME.match(reference):
        raise PathEscape(source, f"{what} {reference!r} uses a URL scheme; only relative paths (and package:// "
                                 f"through {PACKAGE_MAP}) are allowed")
    posix = PurePosixPath(reference.replace("\\", "/"))
    if posix.is_absolute() or re.match(r"^[A-Za-z]:", reference):
        raise PathEscape(source, f"{what} {reference!r} is absolute; only paths inside {os.fspath(base_dir)!r}")
    if ".." in posix.parts:
        raise PathEscape(source, f"{what} {reference!r} contains '..'; only paths inside {os.fspath(base_dir)!r}")
    return confined(base_dir / Path(*posix.parts), base_dir, source)
