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
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([seed, 55])
    for k in range(count):
        kind = KINDS[k % len(KINDS)]
        mesh = _shape(kind, rng)
        path = folder / f"{kind}_{k:03d}.obj"
        if not path.is_file():
            path.write_text(mesh.export(file_type="obj"))
    (folder / "objects.yaml").write_text("units: m\n")
    return folder
