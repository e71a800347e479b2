"""Seeded household-sized shapes to label picks on (issue 55): boxes, cylinders, capsules and ellipsoids of the
sizes groceries come in (2-9 cm across, 3-22 cm tall), written as OBJ files in metres. No household mesh of the
held-out set is among them: they are made here, from a seed.

    from benchmarks.experiments.training_shapes import training_shapes
    folder = training_shapes(Path("data/shapes"), count=160, seed=0)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

KINDS = ("box", "cylinder", "capsule", "ellipsoid")


def _shape(kind: str, rng: np.random.Generator):
    import trimesh

    if kind == "box":
        return trimesh.creation.box(extents=[rng.uniform(0.02, 0.09), rng.uniform(0.03, 0.12),
                                             rng.uniform(0.03, 0.22)])
    if kind == "cylinder":
        return trimesh.creation.cylinder(radius=rng.uniform(0.012, 0.045), height=rng.uniform(0.03, 0.2),
                                         sections=32)
    if kind == "capsule":
        return trimesh.creation.capsule(radius=rng.uniform(0.012, 0.035), height=rng.uniform(0.02, 0.14),
                                        count=[16, 16])
    ellipsoid = trimesh.creation.icosphere(subdivisions=3)
    ellipsoid.apply_scale(rng.uniform([0.015, 0.015, 0.015], [0.05, 0.06, 0.08]))
    return ellipsoid


def training_shapes(folder: Path, count: int, seed: int = 0) -> Path:
    """``count`` shapes in ``folder`` (made once; the same seed makes the same files)."""
    return _written(folder, count, np.random.default_rng([seed, 55]), KINDS, _shape)


def _written(folder: Path, count: int, rng: np.random.Generator, kinds: tuple[str, ...], make) -> Path:
    """``count`` meshes ``make(kind, rng)`` of ``kinds`` in turn, each written once as ``<kind>_<k>.obj``."""
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(count):
        kind = kinds[k % len(kinds)]
        mesh = make(kind, rng)
        path = folder / f"{kind}_{k:03d}.obj"
        if not path.is_file():
            path.write_text(mesh.export(file_type="obj"))
    (folder / "objects.yaml").write_text("units: m\n")
    return folder


VESSELS = ("flat_box", "cup", "bowl", "bottle")


def _revolved(profile: list[tuple[float, float]]):
    """A solid of revolution about z from a (radius, height) profile that starts and ends on the axis."""
    import trimesh

    return trimesh.creation.revolve(np.asarray(profile, dtype=np.float64), sections=32)


def _vessel(kind: str, rng: np.random.Generator):
    """Household shapes the first kinds lack: flat packages (1-3.5 cm thin), cups with a handle, bowls with a
    thin wall and bottles with a neck."""
    import trimesh

    if kind == "flat_box":
        return trimesh.creation.box(extents=[rng.uniform(0.04, 0.1), rng.uniform(0.03, 0.09),
                                             rng.uniform(0.01, 0.035)])
    if kind == "cup":
        radius, height, wall = rng.uniform(0.028, 0.045), rng.uniform(0.06, 0.11), rng.uniform(0.003, 0.006)
        cup = _revolved([(0, 0), (radius, 0), (radius, height), (radius - wall, height),
                         (radius - wall, wall), (0, wall)])
        handle = trimesh.creation.torus(major_radius=height / 4, minor_radius=0.005, major_sections=24,
                                        minor_sections=8)
        handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
        handle.apply_translation([radius, 0, height / 2])
        return trimesh.util.concatenate([cup, handle])
    if kind == "bowl":
        radius, height, wall = rng.uniform(0.04, 0.075), rng.uniform(0.03, 0.065), rng.uniform(0.003, 0.006)
        base = radius * rng.uniform(0.4, 0.6)
        return _revolved([(0, 0), (base, 0), (radius, height), (radius - wall, height), (base - wall, wall),
                          (0, wall)])
    radius, height = rng.uniform(0.02, 0.04), rng.uniform(0.12, 0.22)
    neck, shoulder = rng.uniform(0.009, 0.015), height * rng.uniform(0.55, 0.75)
    return _revolved([(0, 0), (radius, 0), (radius, shoulder), (neck, shoulder + 2 * (radius - neck)),
                      (neck, height), (0, height)])


def vessel_shapes(folder: Path, count: int, seed: int = 0) -> Path:
    """``count`` vessels (VESSELS, in turn) in ``folder`` (made once; the same seed makes the same files)."""
    return _written(folder, count, np.random.default_rng([seed, 56]), VESSELS, _vessel)
