"""The installed version of this package: in every dataset's provenance, compared by client and cluster before a
submit, printed by ``onepiece version``."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version


def package_version() -> str:
    """The installed version of onepiece-dist; '0+unknown' where it runs from a tree that was never installed."""
    try:
        return version("onepiece-dist")
    except PackageNotFoundError:
        return "0+unknown"
