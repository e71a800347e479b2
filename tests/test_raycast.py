"""core.raycast: ray hits that Embree's kernel does not decide."""

import numpy as np
import pytest

from onepiece_dist.core.mesh import box_mesh, sphere_mesh
from onepiece_dist.core.raycast import cast_rays, embree_faces, exact_hits, ring_pairs


def unwelded(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same surface with three vertices of its own per face (as many OBJ and STL files store it)."""
    return vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3)


def test_hits_inside_a_box_are_its_half_extents_with_the_face_normals():
    box = box_mesh((0.04, 0.06, 0.1))
    directions = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]])
    hits = cast_rays(box.vertices, box.faces, np.zeros((3, 3)), directions)
    assert hits.t == pytest.approx([0.02, 0.03, 0.05], rel=1e-14)  # the closed form to float64 rounding
    assert np.allclose(np.abs(np.sum(hits.normal * directions, axis=1)), 1.0)
    assert np.all(hits.face >= 0)


def test_the_hit_does_not_depend_on_which_triangle_of_its_ring_embree_names():
    """Another kernel may name the other triangle at an edge, or a neighbour: the answer stays the same bits."""
    sphere = sphere_mesh(0.05, rings=10, sectors=20)
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(400, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = rng.normal(size=(400, 3)) * 0.01
    named = embree_faces(sphere.vertices, sphere.faces, origins, directions)
    base = exact_hits(sphere.vertices, sphere.faces, origins, directions, named)
    ray, member = ring_pairs(sphere.vertices, sphere.faces, named)
    neighbour = np.full(len(named), -1)
    neighbour[ray] = member  # the last ring member of each ray: a triangle sharing a vertex with the named one
    moved = exact_hits(sphere.vertices, sphere.faces, origins, directions, neighbour)
    assert np.count_nonzero(neighbour != named) > 300
    assert np.array_equal(moved.t, base.t) and np.array_equal(moved.face, base.face)
    assert np.array_equal(moved.normal, base.normal)


def test_a_ray_through_an_edge_hits_the_lower_numbered_triangle_whichever_is_named():
    vertices = np.array([[-1.0, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])  # a square split along its diagonal
    origin, up = np.array([[0.25, 0.25, 0.0]]), np.array([[0.0, 0, 1]])  # x = y: on the shared edge
    for named in (0, 1):
        hits = exact_hits(vertices, faces, origin, up, np.array([named]))
        assert hits.t.tolist() == [1.0] and hits.face.tolist() == [0]


def test_rings_are_found_by_position_on_a_mesh_without_shared_vertices():
    box = box_mesh((0.04, 0.04, 0.04))
    vertices, faces = unwelded(box.vertices, box.faces)
    ray, member = ring_pairs(vertices, faces, np.array([0]))
    shared = np.flatnonzero([len(set(map(tuple, vertices[f])) & set(map(tuple, vertices[faces[0]]))) > 0
                             for f in faces])
    assert set(member.tolist()) == set(shared.tolist()) and set(ray.tolist()) == {0}
    origins, directions = np.zeros((2, 3)), np.array([[0.0, 0, 1], [0.6, 0.8, 0]])
    welded = cast_rays(box.vertices, box.faces, origins, directions)
    assert np.array_equal(cast_rays(vertices, faces, origins, directions).t, welded.t)


def test_a_miss_stays_a_miss_and_nothing_is_nan():
    box = box_mesh((0.04, 0.04, 0.04))
    hits = cast_rays(box.vertices, box.faces, np.array([[1.0, 0, 0], [0, 0, 0]]), np.array([[1.0, 0, 0]] * 2))
    assert hits.t[0] == np.inf and hits.face[0] == -1 and not hits.normal[0].any()
    assert hits.t[1] == pytest.approx(0.02) and not np.isnan(hits.normal).any()


def test_hits_agree_with_embree_to_its_float32_precision_on_a_real_mesh():
    import open3d as o3d

    from onepiece_dist.objects import load_object
    from onepiece_dist.objects.sources import resolve_source
    from onepiece_dist.specs.job import JobSpec

    mesh = load_object(resolve_source("pybullet:named[3:4]")[0], JobSpec()).mesh
    rng = np.random.default_rng(1)
    pick = rng.choice(len(mesh.faces), 2000)
    points = mesh.vertices[mesh.faces[pick]].mean(axis=1)
    directions = rng.normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    hits = cast_rays(mesh.vertices, mesh.faces, points - 1e-4 * directions, directions)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                        o3d.core.Tensor(mesh.faces.astype(np.uint32)))
    embree = scene.cast_rays(o3d.core.Tensor(np.hstack([points - 1e-4 * directions, directions]).astype(np.float32)))
    t = embree["t_hit"].numpy().astype(np.float64)
    both = np.isfinite(t) & np.isfinite(hits.t)
    assert both.mean() > 0.95 and np.array_equal(np.isfinite(t), np.isfinite(hits.t))
    assert np.abs(t[both] - hits.t[both]).max() < 1e-5


def test_open3d_is_imported_without_plotly_and_still_casts_and_its_plotly_calls_say_why_not():
    """core.raycast.import_open3d: a worker that samples grasps loads open3d without plotly and dash (half of its
    import time), Embree's ray casts work there, and open3d's plotly drawing says how to have it."""
    import subprocess
    import sys

    probe = ("import sys, numpy as np\n"
             "from onepiece_dist.core.mesh import box_mesh\n"
             "from onepiece_dist.core.raycast import cast_rays, import_open3d\n"
             "box = box_mesh((0.1, 0.1, 0.1))\n"
             "hits = cast_rays(box.vertices, box.faces, np.zeros((1, 3)), np.array([[1.0, 0, 0]]))\n"
             "assert abs(hits.t[0] - 0.05) < 1e-12, hits.t\n"
             "assert not {'plotly', 'dash'} & set(sys.modules), sorted({'plotly', 'dash'} & set(sys.modules))\n"
             "try:\n"
             "    import_open3d().visualization.draw_plotly([])\n"
             "except RuntimeError as err:\n"
             "    print(err)\n")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "import open3d before onepiece_dist" in out.stdout
