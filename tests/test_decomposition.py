"""CoACD beside VHACD (issue 50): an L cut into its two arms, the same pieces on every run, and a job that asks
for it uses it (docs/decomposition.md measures both on time and label agreement)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from onepiece_dist.core.mesh import box_mesh, make_mesh, merge_meshes
from onepiece_dist.sim.collision import convex_pieces
from onepiece_dist.specs.job import JobSpec

pytestmark = pytest.mark.sim


def l_shape():
    arm, post = box_mesh((0.1, 0.02, 0.02)), box_mesh((0.02, 0.02, 0.08))
    return make_mesh(*merge_meshes([(arm.vertices, arm.faces), (post.vertices + [0.04, 0, 0.05], post.faces)]), "L")


def test_coacd_cuts_an_l_into_convex_arms_that_fill_it_and_repeats_itself(tmp_path):
    pytest.importorskip("coacd", reason="CoACD is the extra 'decompose' (installed with dev)")
    mesh = l_shape()
    pieces = convex_pieces(mesh, tmp_path / "a", "coacd")
    again = convex_pieces(mesh, tmp_path / "b", "coacd")
    assert len(pieces) >= 2 and all(np.array_equal(p, q) for p, q in zip(pieces, again, strict=True))
    solid = 0.1 * 0.02 * 0.02 + 0.02 * 0.02 * 0.08
    assert sum(ConvexHull(p).volume for p in pieces) == pytest.approx(solid, rel=0.2)
    assert ConvexHull(mesh.vertices).volume > 1.5 * solid  # the hull alone would fill the L's elbow
    cached = sorted(path.name for path in (tmp_path / "a").iterdir())
    assert cached == [f"{mesh.content_id}-coacd0.05.obj"]
    assert JobSpec(sim={"collision": "coacd"}).sim.collision == "coacd"
