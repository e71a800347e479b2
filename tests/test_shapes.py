"""The seeded household-sized shapes every command can name (``shapes:groceries[a:b]``, ``shapes:vessels[a:b]``,
objects.shapes): a slice names the same shapes wherever it is resolved, each loads as a closed solid of its kind's
sizes, and an unknown set is refused naming the known ones."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from onepiece_dist.core.repair import closed_volume, connected_pieces
from onepiece_dist.errors import SourceError
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec


def _loaded(source: str, tmp_path):
    job = JobSpec(objects=source, output=str(tmp_path / "unused.zarr"))
    return [load_object(ref, job) for ref in resolve_source(source)]


def test_a_slice_names_the_same_shapes_wherever_it_is_resolved(tmp_path):
    for name in ("groceries", "vessels"):
        whole = _loaded(f"shapes:{name}[0:8]", tmp_path)
        tail = _loaded(f"shapes:{name}[4:8]", tmp_path)
        assert [o.mesh.content_id for o in whole[4:]] == [o.mesh.content_id for o in tail]
        assert [o.ref.name for o in tail] == [o.ref.name for o in whole[4:]]
        assert len({o.mesh.content_id for o in whole}) == 8  # each its own shape
    assert len(resolve_source("shapes:groceries")) == 1000


@pytest.mark.parametrize("name", ["groceries", "vessels"])
def test_each_shape_is_a_closed_solid_of_its_kind(name, tmp_path):
    for loaded in _loaded(f"shapes:{name}[0:8]", tmp_path):
        vertices, faces = loaded.mesh.vertices, loaded.mesh.faces
        assert loaded.repairs == ()  # nothing to weld, flip or cap
        volume, holes = closed_volume(vertices, faces)
        assert holes == 0 and volume > 0, loaded.ref.name
        solid = trimesh.Trimesh(vertices, faces, process=False)
        assert solid.is_winding_consistent and solid.volume > 0
        extents = np.sort(loaded.mesh.extents)
        assert 0.009 < extents[0] and extents[-1] < 0.23, (loaded.ref.name, extents)
        kind = loaded.ref.name.split("/")[1].rsplit("_", 1)[0]
        hollow = solid.volume / solid.convex_hull.volume
        if kind == "flat_box":
            assert extents[0] <= 0.035 and hollow > 0.99
        if kind in ("cup", "bowl"):
            assert hollow < 0.6, (loaded.ref.name, hollow)  # a thin wall around an open space
        assert connected_pieces(faces, len(vertices)) == (2 if kind == "cup" else 1)  # a cup's handle


def test_an_unknown_set_is_refused_naming_the_known_ones():
    with pytest.raises(SourceError, match=r"shapes:toys.*shapes:groceries\[a:b\], shapes:vessels\[a:b\]"):
        resolve_source("shapes:toys[0:3]")
    assert resolve_source("shapes:vessels[2000:2010]") == []


def test_pick_labels_default_objects_resolve_and_load_without_a_fetch(tmp_path):
    from onepiece_dist.specs.plan import PickLabelSpec

    spec = PickLabelSpec()
    loaded = _loaded(spec.objects, tmp_path)
    kinds = [o.ref.name.split("/")[0] for o in loaded]
    assert kinds.count("random_urdfs") == kinds.count("groceries") + kinds.count("vessels") > 0
    assert len({o.content_id for o in loaded}) == len(loaded)  # no object twice
