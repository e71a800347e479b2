"""`onepiece supplement`: scans become watertight object meshes, degenerate scans are refused."""

import json
from pathlib import Path

import numpy as np
import open3d as o3d
import pytest
import trimesh
from typer.testing import CliRunner

from onepiece_dist.cli.main import app
from onepiece_dist.core.mesh import box_mesh, make_mesh, sample_surface
from onepiece_dist.core.repair import fan_fill
from onepiece_dist.errors import MeshRejected
from onepiece_dist.objects.meshio import parse_mesh_bytes
from onepiece_dist.objects.supplement import estimate_normals, hausdorff, supplement_scan
from onepiece_dist.runtime.local import run_local
from tests.factories import noisy_scan, torus_mesh

HAUSDORFF_TOLERANCE = 0.003  # m, for a 5-10 cm object scanned with 0.5 mm noise and 2 % outliers


def read_result(path) -> trimesh.Trimesh:
    vertices, faces = parse_mesh_bytes(open(path, "rb").read(), ".obj", str(path))
    return trimesh.Trimesh(vertices, faces, process=False)


def distance_to_original(result: trimesh.Trimesh, original, rng) -> float:
    points, _ = sample_surface(original, 20000, rng)
    return hausdorff(points, make_mesh(result.vertices, result.faces, "result"))[0]


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["box", "torus"])
def test_a_noisy_scan_with_outliers_becomes_a_watertight_close_mesh(shape, tmp_path):
    rng = np.random.default_rng(3)
    original = box_mesh((0.06, 0.04, 0.1)) if shape == "box" else torus_mesh()
    scan = tmp_path / f"{shape}.xyz"
    np.savetxt(scan, noisy_scan(original, rng))
    report = supplement_scan(scan, tmp_path / "out")
    result = read_result(report.mesh)
    assert report.watertight and result.is_watertight
    assert report.outliers_removed >= 300  # 400 planted, a few lie on the surface
    assert distance_to_original(result, original, rng) < HAUSDORFF_TOLERANCE
    true_volume = abs(trimesh.Trimesh(original.vertices, original.faces).volume)
    assert abs(report.volume_m3 - true_volume) < 0.03 * true_volume
    assert json.loads((tmp_path / "out" / f"{shape}.supplement.json").read_text())["hausdorff_m"] == report.hausdorff_m


def test_a_scan_in_millimetres_with_normals_is_scaled_to_metres(tmp_path):
    points, normals = sample_surface(box_mesh((0.05, 0.03, 0.07)), 15000, np.random.default_rng(0))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points * 1000))
    cloud.normals = o3d.utility.Vector3dVector(normals)
    o3d.io.write_point_cloud(str(tmp_path / "part.ply"), cloud)
    report = supplement_scan(tmp_path / "part.ply", tmp_path / "out")
    assert report.units == "mm" and report.normals == "given" and report.watertight
    assert np.allclose(report.extents_m, [0.05, 0.03, 0.07], atol=0.003)


def test_a_scan_missing_one_side_is_closed_and_says_so(tmp_path):
    points, _ = sample_surface(box_mesh((0.06, 0.04, 0.1)), 20000, np.random.default_rng(1))
    np.savetxt(tmp_path / "open.xyz", points[points[:, 2] < 0.049])  # the top face was never captured
    report = supplement_scan(tmp_path / "open.xyz", tmp_path / "out")
    assert report.watertight and report.holes_filled
    assert any("holes were closed" in w for w in report.warnings)


def test_normals_of_an_exactly_planar_faced_box_all_point_outward():
    """Exactly coplanar samples, where open3d's orientation graph degenerates (orientation runs on jittered
    copies): every normal points away from the centre, and off the edges along its face's normal."""
    points, face_normals = sample_surface(box_mesh((0.06, 0.04, 0.1)), 6000, np.random.default_rng(2))
    normals = estimate_normals(points)
    assert np.all(np.einsum("ij,ij->i", normals, points - points.mean(axis=0)) > 0)
    assert np.mean(np.einsum("ij,ij->i", normals, face_normals) > 0.9) > 0.9  # near edges they tilt, never flip


@pytest.mark.parametrize("points, reason", [
    (np.random.default_rng(0).uniform(0, 0.05, (50, 3)), "too few points"),
    (np.c_[np.random.default_rng(0).uniform(0, 0.1, (3000, 2)), np.zeros(3000)], "scan is flat"),
])
def test_a_degenerate_scan_is_refused_with_the_reason(points, reason, tmp_path):
    np.savetxt(tmp_path / "bad.xyz", points)
    with pytest.raises(MeshRejected, match=reason):
        supplement_scan(tmp_path / "bad.xyz", tmp_path / "out")
    result = CliRunner().invoke(app, ["supplement", str(tmp_path / "bad.xyz"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1 and reason in result.output
    assert not (tmp_path / "out" / "bad.obj").exists()


def test_unreadable_or_unknown_scans_are_refused(tmp_path):
    with pytest.raises(MeshRejected, match="no such scan file"):
        supplement_scan(tmp_path / "missing.ply", tmp_path / "out")
    (tmp_path / "scan.las").write_text("x")
    with pytest.raises(MeshRejected, match="unsupported scan extension"):
        supplement_scan(tmp_path / "scan.las", tmp_path / "out")


def test_fan_fill_closes_a_missing_face_with_matching_winding():
    box = box_mesh((0.02, 0.02, 0.02))
    vertices, faces = fan_fill(box.vertices, box.faces[2:])  # two triangles = one square face removed
    closed = trimesh.Trimesh(vertices, faces, process=False)
    assert closed.is_watertight and closed.is_winding_consistent
    assert closed.volume == pytest.approx(0.02**3, rel=1e-6)


@pytest.mark.slow
def test_the_supplemented_mesh_drops_into_a_job(spec_factory, tmp_path):
    np.savetxt(tmp_path / "torus.xyz", noisy_scan(torus_mesh(), np.random.default_rng(5)))
    CliRunner().invoke(app, ["supplement", str(tmp_path / "torus.xyz"), "--out", str(tmp_path / "objects")])
    spec = spec_factory(objects=str(tmp_path / "objects"), sim={"physics": False})
    final = run_local(spec)
    assert final.state == "succeeded"
    assert final.progress.objects_done == 1 and not final.rejections and final.progress.grasps > 0


@pytest.mark.slow
def test_the_same_scan_gives_the_same_bytes_and_a_watertight_report_holds(tmp_path):
    """Issue 50 item 6: Poisson reconstruction on one thread; before, each run of this torus gave other bytes."""
    import hashlib

    scan = tmp_path / "torus.xyz"
    np.savetxt(scan, noisy_scan(torus_mesh(), np.random.default_rng(5)))
    reports = [supplement_scan(scan, tmp_path / f"out{k}") for k in range(2)]
    digests = {hashlib.sha256(Path(r.mesh).read_bytes()).hexdigest() for r in reports}
    assert len(digests) == 1
    assert reports[0].watertight and read_result(reports[0].mesh).is_watertight
