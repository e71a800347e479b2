"""Path confinement: input paths never escape their root."""

from __future__ import annotations

import os
import re
from pathlib import Path, PurePosixPath

from onepiece_dist.errors import PathEscape

_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


def confined(path: str | os.PathLike, root: str | os.PathLike, source: str) -> Path:
    """Real path of ``path`` if it lies inside ``root`` (symlinks followed), else :class:`PathEscape`."""
    real_root = os.path.realpath(root)
    real = os.path.realpath(path)
    if os.path.commonpath([real_root, real]) != real_root:
        raise PathEscape(source, f"path {os.fspath(path)!r} resolves to {real!r}, outside its root {real_root!r}")
    return Path(real)


def relative_reference(reference: str, base_dir: Path, source: str) -> Path:
    """Resolve a file name written inside a file (a URDF mesh) strictly under that file's folder.

    Absolute paths, URL schemes (file://, package://, http://), '..' components and symlinks that leave
    ``base_dir`` are refused.
    """
    if _SCHEME.match(reference):
        raise PathEscape(source, f"mesh path {reference!r} uses a URL scheme; only relative paths are allowed")
    posix = PurePosixPath(reference.replace("\\", "/"))
    if posix.is_absolute() or re.match(r"^[A-Za-z]:", reference):
        raise PathEscape(source, f"mesh path {reference!r} is absolute; only paths inside the URDF's folder")
    if ".." in posix.parts:
        raise PathEscape(source, f"mesh path {reference!r} contains '..'; only paths inside the URDF's folder")
    return confined(base_dir / Path(*posix.parts), base_dir, source)
