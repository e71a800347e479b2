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


def test_the_vhacd_child_serves_every_object_as_a_child_of_its_own_would_and_outlives_a_crash(tmp_path):
    """One VHACD child serves a process's objects (sim.collision.VhacdChild): each object's pieces are the bytes a
    fresh child per object (the way before) writes, and a child killed between objects (as a crash on a mesh
    ends it) is replaced at the next object, which gets its pieces."""
    import os
    import subprocess
    import sys

    from benchmarks.speed.bench_worker_start import FRESH_CHILD
    from onepiece_dist.core.mesh import cylinder_mesh, sphere_mesh
    from onepiece_dist.objects.meshio import write_obj
    from onepiece_dist.sim import collision

    meshes = [l_shape(), sphere_mesh(0.03), cylinder_mesh(0.02, 0.08)]
    for k, mesh in enumerate(meshes):
        if k == 2:
            collision._VHACD._child.kill()  # the child dies between two objects
        pieces = convex_pieces(mesh, tmp_path / "served", "vhacd")
        source = tmp_path / f"{k}.obj"
        write_obj(mesh.vertices, mesh.faces, source)
        subprocess.run([sys.executable, "-c", FRESH_CHILD, str(source), str(tmp_path / f"{k}.vhacd.obj"),
                        os.devnull, "50000"], capture_output=True, check=True)
        served = tmp_path / "served" / f"{mesh.content_id}-vhacd50000.obj"
        assert len(pieces) >= 1 and served.read_bytes() == (tmp_path / f"{k}.vhacd.obj").read_bytes()
    assert sorted(p.suffix for p in (tmp_path / "served").iterdir()) == [".obj"] * 3  # no source or part left


def test_a_vhacd_child_past_its_time_is_ended_and_the_object_gets_no_pieces_from_it(tmp_path, monkeypatch):
    from onepiece_dist.sim import collision

    monkeypatch.setattr(collision, "_VHACD_SCRIPT", "import sys, time\nfor line in sys.stdin:\n    time.sleep(60)")
    child = collision.VhacdChild()
    assert child.run(tmp_path / "in.obj", tmp_path / "out.obj", 50_000, timeout=1.0) is False
    assert child._child is None and not (tmp_path / "out.obj").exists()


def files_and_times(folder):
    return {path.name: path.stat().st_mtime_ns for path in folder.iterdir()}


def test_local_jobs_share_the_users_decompositions_and_hold_what_a_job_of_its_own_makes(tmp_path, monkeypatch):
    """Local runs (api.run_job) keep decompositions in this user's cache folder: a second job on the same objects
    decomposes nothing and writes none beside its parts, and both hold the content of a job that decomposed
    everything itself in its parts folder (run_local with the spec as given)."""
    from onepiece_dist.api import run_job
    from onepiece_dist.runtime.local import run_local
    from onepiece_dist.sim.collision import user_decompositions
    from onepiece_dist.store import open_dataset
    from onepiece_dist.store.dataset import content_digest
    from tests.factories import small_spec

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = user_decompositions()
    assert folder.parent == tmp_path / "cache" / "onepiece" / "decompositions" and folder.name.startswith("pybullet-")
    assert folder.stat().st_mode & 0o777 == 0o700
    first, second = (small_spec(tmp_path / name, objects="primitives[0:2]", grasps_per_object=8)
                     for name in ("first", "second"))
    run_job(first, in_process=True)
    made = files_and_times(folder)
    assert len([name for name in made if name.endswith("-vhacd50000.obj")]) == 2, made
    run_job(second, in_process=True)
    assert files_and_times(folder) == made  # nothing decomposed again
    assert not (tmp_path / "second" / "ds.zarr.parts" / "collision").exists()
    assert open_dataset(second.output).attrs["job_spec"]["decompositions"] == str(folder)
    own = small_spec(tmp_path / "own", objects="primitives[0:2]", grasps_per_object=8)
    run_local(own)
    assert sorted(p.name for p in (tmp_path / "own" / "ds.zarr.parts" / "collision").iterdir()) == sorted(made)
    assert content_digest(first.output) == content_digest(second.output) == content_digest(own.output)


def test_a_job_for_a_cluster_names_its_decompositions_folder_absolutely(tmp_path):
    from onepiece_dist.api import check_remote_paths
    from onepiece_dist.errors import SpecError

    check_remote_paths(JobSpec(output=str(tmp_path / "a.zarr"), decompositions=str(tmp_path / "d")))
    with pytest.raises(SpecError, match="decompositions: 'shared/decompositions' is relative"):
        check_remote_paths(JobSpec(output=str(tmp_path / "a.zarr"), decompositions="shared/decompositions"))


def test_a_damaged_decomposition_in_the_folder_is_made_again_not_loaded(tmp_path):
    """A shared folder's file that does not read as a decomposition (damaged on disk) is replaced by a fresh one,
    and the object gets the fresh pieces, not a rejection every later job would meet too."""
    mesh = l_shape()
    fresh = convex_pieces(mesh, tmp_path / "fresh", "vhacd")
    made = (tmp_path / "fresh" / f"{mesh.content_id}-vhacd50000.obj").read_bytes()
    for damage in (b"\xff\xfe not text", b"v 0 0\nf 1 2 3\n"):
        damaged = tmp_path / "shared" / f"{mesh.content_id}-vhacd50000.obj"
        damaged.parent.mkdir(exist_ok=True)
        damaged.write_bytes(damage)
        pieces = convex_pieces(mesh, tmp_path / "shared", "vhacd")
        assert damaged.read_bytes() == made
        assert len(pieces) == len(fresh) and all(np.array_equal(a, b) for a, b in zip(pieces, fresh, strict=True))
