"""The seeded training shapes the pick labels are made on (benchmarks/experiments/training_shapes.py): the same
seed makes the same files, every one loads as an object in metres, and the vessels are what they are named."""

from __future__ import annotations

import numpy as np
import trimesh

from benchmarks.experiments.training_shapes import VESSELS, training_shapes, vessel_shapes
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec


def _bytes(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.glob("*.obj"))}


def test_a_seed_makes_the_same_shapes_and_another_seed_others(tmp_path):
    for make in (training_shapes, vessel_shapes):
        one, again, other = (make(tmp_path / f"{make.__name__}{k}", 8, seed) for k, seed in enumerate((0, 0, 1)))
        assert _bytes(one) == _bytes(again) and _bytes(one) != _bytes(other)
        assert set(_bytes(one)) == set(_bytes(other))


def test_every_vessel_loads_and_is_the_kind_it_is_named(tmp_path):
    folder = vessel_shapes(tmp_path / "vessels", 2 * len(VESSELS), seed=3)
    job = JobSpec(objects=str(folder), output=str(tmp_path / "unused.zarr"))
    for ref in resolve_source(str(folder)):
        load_object(ref, job)  # validated and accepted as it is
        mesh = trimesh.load(folder / ref.name, force="mesh")
        extents = np.sort(mesh.extents)
        assert mesh.is_watertight and 0.009 < extents[0] and extents[-1] < 0.23, (ref.name, extents)
        hollow = mesh.volume / mesh.convex_hull.volume
        if ref.name.startswith("flat_box"):
            assert extents[0] <= 0.035 and hollow > 0.99
        if ref.name.startswith(("cup", "bowl")):
            assert hollow < 0.6, (ref.name, hollow)  # a thin wall around an open space
