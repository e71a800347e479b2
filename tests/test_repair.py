"""Mesh repairs (issue 50): UV-seam welding, inward winding, disconnected pieces and open surfaces, each said in
the object's ingest record; the mass of an open scan from its volume with the holes capped."""

from __future__ import annotations

import numpy as np
import pytest

from onepiece_dist.core.mesh import box_mesh, enclosed_volume, signed_volume
from onepiece_dist.core.repair import boundary_edges, closed_volume, connected_pieces, weld
from onepiece_dist.objects import load_object, resolve_source
from onepiece_dist.specs.job import JobSpec

CUBE = box_mesh((0.04, 0.06, 0.08))


def split_at_every_face(vertices, faces):
    """Each face with corners of its own, as a textured scan stores a position once per texture chart."""
    return vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3)


def test_welding_a_mesh_split_at_its_seams_gives_back_the_shared_vertices():
    vertices, faces = split_at_every_face(CUBE.vertices, CUBE.faces)
    welded, welded_faces, merged = weld(vertices, faces)
    assert (len(vertices), len(welded), merged) == (36, 8, 28)
    assert len(boundary_edges(faces)) == 36 and len(boundary_edges(welded_faces)) == 0
    assert closed_volume(welded, welded_faces) == (pytest.approx(0.04 * 0.06 * 0.08, rel=1e-12), 0)
    assert np.array_equal(welded[welded_faces], vertices[faces])  # the same triangles, corner for corner
    same, same_faces, none = weld(CUBE.vertices, CUBE.faces)
    assert none == 0 and same is CUBE.vertices and same_faces is CUBE.faces


def test_an_open_box_gets_its_volume_with_the_hole_capped_wherever_the_origin_lies():
    top = CUBE.vertices[CUBE.faces].mean(axis=1)[:, 2] > 0.039
    faces = CUBE.faces[~top]
    for shift in (np.zeros(3), np.array([0.5, -0.3, 2.0])):
        vertices = CUBE.vertices + shift
        assert closed_volume(vertices, faces) == (pytest.approx(0.04 * 0.06 * 0.08, rel=1e-9), 1)
    shifted = CUBE.vertices + [0.5, -0.3, 2.0]
    assert abs(signed_volume(shifted, faces) - 0.04 * 0.06 * 0.08) > 1e-4  # uncapped: the origin decides
    assert closed_volume(shifted, faces[:, ::-1])[0] == pytest.approx(-0.04 * 0.06 * 0.08, rel=1e-9)


def test_two_boxes_are_two_pieces_and_one_box_one():
    assert connected_pieces(np.vstack([CUBE.faces, CUBE.faces + 8]), 16) == 2
    assert connected_pieces(CUBE.faces, 8) == 1


def obj_text(vertices, faces, uv_split: bool) -> str:
    """An OBJ with texture coordinates; with ``uv_split`` every face has vertices of its own (the seams)."""
    if uv_split:
        vertices, faces = split_at_every_face(vertices, faces)
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices] + ["vt 0.5 0.5"]
    lines += [f"f {a + 1}/1 {b + 1}/1 {c + 1}/1" for a, b, c in faces]
    return "\n".join(lines) + "\n"


def test_a_scan_split_at_seams_open_and_inward_is_repaired_and_says_so(tmp_path):
    top = CUBE.vertices[CUBE.faces].mean(axis=1)[:, 2] > 0.039
    path = tmp_path / "scan.obj"
    path.write_text(obj_text(CUBE.vertices + [0.3, 0.3, 0.3], CUBE.faces[~top][:, ::-1], uv_split=True))
    loaded = load_object(resolve_source(str(path))[0], JobSpec())
    assert loaded.repairs == ("22 vertices split at UV seams or duplicated: welded (8 remain)",
                              "faces wound inwards (negative enclosed volume): flipped",
                              "open surface (4 rim edges, 1 holes): mass from the volume with its holes capped")
    assert enclosed_volume(loaded.mesh) == pytest.approx(0.04 * 0.06 * 0.08, rel=1e-9)
    assert len(loaded.mesh.faces) == 10 and closed_volume(loaded.mesh.vertices, loaded.mesh.faces)[0] > 0
    whole = tmp_path / "whole.obj"
    whole.write_text(obj_text(CUBE.vertices, CUBE.faces, uv_split=False))
    assert load_object(resolve_source(str(whole))[0], JobSpec()).repairs == ()
