"""core.portable: sine and cosine within one ULP of the C library's, and the same bits whichever CPU kernels run."""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from onepiece_dist.core import portable

# x86-64 CPUs differ in what numpy, glibc's libm and OpenBLAS pick for them: these turn this machine's picks off,
# as a CPU without AVX2 and FMA would have them (numpy ignores names it does not know, glibc too).
OLDER_CPU = {"OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": "X86_V3",
             "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX"}


def ulps(found: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|found - exact| in units of the last place of ``exact``. -> like exact, float64"""
    return np.abs(found - exact) / np.spacing(np.maximum(np.abs(exact), 1e-300))


@pytest.mark.parametrize("bound", [math.pi / 4, 7.0, 200.0, 9.9e4])
def test_sine_and_cosine_are_within_one_ulp_of_the_c_library(bound):
    angles = np.random.default_rng(0).uniform(-bound, bound, 20000)
    sin, cos = portable.sin_cos(angles)
    assert ulps(sin, np.array([math.sin(a) for a in angles])).max() <= 1.0
    assert ulps(cos, np.array([math.cos(a) for a in angles])).max() <= 1.0


def test_quarter_turns_symmetry_and_shapes():
    quarter = np.arange(-8, 9) * (math.pi / 2)
    sin, cos = portable.sin_cos(quarter)
    assert np.allclose(sin, np.sin(quarter), atol=1e-15) and np.allclose(cos, np.cos(quarter), atol=1e-15)
    angles = np.random.default_rng(1).uniform(0, 50, (7, 3))
    sin, cos = portable.sin_cos(angles)
    assert sin.shape == cos.shape == (7, 3)
    assert np.array_equal(portable.sin(-angles), -sin) and np.array_equal(portable.cos(-angles), cos)
    assert np.allclose(sin**2 + cos**2, 1.0, atol=4e-16)
    assert float(portable.tan(math.pi / 4)) == pytest.approx(1.0, abs=2e-16)
    assert float(portable.sin(0.0)) == 0.0 and float(portable.cos(0.0)) == 1.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, 2.0e5])
def test_an_angle_it_cannot_reduce_is_named(bad):
    with pytest.raises(ValueError, match="angle"):
        portable.sin_cos(np.array([0.5, bad]))


def pose_digests() -> dict[str, str]:
    """blake2b digests of the float64 arrays a job hands to the physics or computes from angles: the samplers'
    candidate poses, the label trajectory, a perturbed pose, composed and inverted poses, a URDF origin, the
    cameras' directions, a primitive mesh; and the products that crop points into gripper frames."""
    import xml.etree.ElementTree as ET

    from onepiece_dist.core.frames import (
        compose_poses,
        gripper_frame_batches,
        invert_poses,
        perturb_pose,
        to_gripper_frame,
        transform_points,
    )
    from onepiece_dist.core.mesh import cylinder_mesh, sample_surface
    from onepiece_dist.core.sampling import object_rng, sample_candidates
    from onepiece_dist.objects.urdf import _origin
    from onepiece_dist.sim.trials import _trajectory
    from onepiece_dist.sim.views import sphere_directions
    from onepiece_dist.specs.job import GripperSpec, SamplerSpec

    mesh = cylinder_mesh(0.02, 0.1)
    arrays = {"angles": np.concatenate(portable.sin_cos(np.random.default_rng(2).uniform(-9, 9, 5000))),
              "mesh": mesh.vertices, "trajectory": np.concatenate([a.ravel() for a in _trajectory(1 / 240)]),
              "perturbed": perturb_pose(np.eye(4), np.random.default_rng(3), 0.002, 0.05),
              "origin": _origin(ET.fromstring('<origin xyz="0 0 0" rpy="0.3 -1.2 2.5"/>'), "test"),
              "directions": sphere_directions(40)}
    for method in ("antipodal", "normal"):
        rng = object_rng(mesh.content_id, 0)
        points, normals = sample_surface(mesh, 4000, rng)
        found = sample_candidates(mesh, points, normals, 40, GripperSpec(), SamplerSpec(method=method), rng)
        arrays[method] = found.poses
    arrays["composed"] = compose_poses(invert_poses(arrays["normal"]), arrays["antipodal"])
    cloud = np.random.default_rng(4).normal(size=(3000, 3)) * 0.03  # the crops' and collision probe's products
    arrays["gripper_frame"] = np.concatenate([c for _, c in gripper_frame_batches(cloud, arrays["antipodal"], 9000)],
                                             axis=1)
    arrays["to_gripper_frame"] = to_gripper_frame(cloud, arrays["antipodal"])
    arrays["transformed"] = transform_points(cloud, arrays["perturbed"])
    return {name: hashlib.blake2b(np.ascontiguousarray(a).tobytes(), digest_size=12).hexdigest()
            for name, a in arrays.items()}


@pytest.mark.skipif(platform.machine() != "x86_64", reason="the CPU kernels turned off are x86-64 ones")
def test_poses_and_trajectories_are_the_same_bits_without_this_cpus_kernels():
    """Run in a process whose numpy, libm and BLAS take the paths of an older CPU: every array computed from an
    angle or handed to the physics must hold the same bits. Before core.portable and the fixed-order products,
    OpenBLAS's SSE kernel moved the perturbed and the normal sampler's poses here (its SVD and matrix products),
    and glibc's non-FMA sine moved a job's candidate poses."""
    env = {**os.environ, **OLDER_CPU}
    out = subprocess.run([sys.executable, __file__], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert json.loads(out.stdout.splitlines()[-1]) == pose_digests()


def test_both_crop_products_give_the_same_bits_and_a_face_on_a_voxel_boundary_one_code():
    """The batched planes and the per-pose product are the same formula; a box face at v = -1 cm lies exactly on
    a voxel boundary, and both crop paths (dense, and through a grid index) put it in the same voxels."""
    from onepiece_dist.core.frames import gripper_frame_batches, pose_from_axes, to_gripper_frame
    from onepiece_dist.core.spatial import PointGrid
    from onepiece_dist.core.voxel import crop_codes

    rng = np.random.default_rng(5)
    poses = pose_from_axes(rng.normal(size=(30, 3)) * 0.01, rng.normal(size=(30, 3)), rng.normal(size=(30, 3)))
    cloud = rng.normal(size=(500, 3)) * 0.03
    batched = np.concatenate([c for _, c in gripper_frame_batches(cloud, poses, pairs=2000)], axis=1)
    assert np.array_equal(np.moveaxis(batched, 0, -1), to_gripper_frame(cloud, poses))
    face = np.column_stack([rng.uniform(0.001, 0.039, 400), np.full(400, -0.01), rng.uniform(-0.009, 0.009, 400)])
    square = pose_from_axes(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]]))
    dense, _ = crop_codes(face, square, (4, 8, 2), 0.01)
    indexed, _ = crop_codes(face, square, (4, 8, 2), 0.01, index=PointGrid(face, 0.01))
    assert np.array_equal(dense, indexed) and dense.any()


if __name__ == "__main__":
    print(json.dumps(pose_digests()))
