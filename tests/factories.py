"""Tiny synthetic inputs built by factory functions."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from onepiece_dist.specs.job import JobSpec


def small_spec(tmp_path: Path, **overrides) -> JobSpec:
    fields = {"objects": "primitives[0:3]", "grasps_per_object": 16, "output": str(tmp_path / "ds.zarr"),
              "sampler": {"surface_points": 3000}, "stages": ["ingest", "extract", "dedup"]}
    fields.update(overrides)
    return JobSpec.model_validate(fields)


def box_obj_text(size: float = 0.04) -> str:
    h = size / 2
    verts = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
             (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    return "".join(f"v {x} {y} {z}\n" for x, y, z in verts) + "".join(f"f {a} {b} {c}\n" for a, b, c in faces)


def urdf_text(mesh_filename: str, scale: float = 1.0) -> str:
    return (f'<robot name="obj"><link name="base"><visual><geometry><mesh filename="{mesh_filename}" '
            f'scale="{scale} {scale} {scale}"/></geometry></visual></link></robot>')


def broken_inputs_folder(root: Path, outside: Path) -> dict[str, str]:
    """Write good and hostile inputs under ``root``; returns {file name: 'ok' or expected reason fragment}.

    ``outside`` is a folder beside ``root`` holding a valid mesh that nothing may open.
    """
    root.mkdir(parents=True, exist_ok=True)
    outside.mkdir(parents=True, exist_ok=True)
    (outside / "secret.obj").write_text(box_obj_text())
    (outside / "secret.mtl").write_text("newmtl x\n")
    good = box_obj_text()
    lines = good.splitlines()
    files = {
        "good_box.obj": (good, "ok"),
        "good_urdf/obj.urdf": (urdf_text("box.obj"), "ok"),
        "good_urdf/box.obj": (good, None),
        "nan_vertices.obj": (good.replace(lines[0], "v nan 0 0"), "not finite"),
        "inf_vertices.obj": (good.replace(lines[1], "v inf 0 0"), "not finite"),
        "empty.obj": ("", "empty"),
        "out_of_range.obj": (good + "f 1 2 99\n", "out of range"),
        "garbage.stl": (None, "cannot parse"),
        "wrong_ext.xyz": ("v 0 0 0\n", "unsupported file extension"),
        "escape_urdf/obj.urdf": (urdf_text("../../outside/secret.obj"), "'..'"),
        "abs_urdf/obj.urdf": (urdf_text(str(outside / "secret.obj")), "absolute"),
        "file_urdf/obj.urdf": (urdf_text(f"file://{outside}/secret.obj"), "URL scheme"),
        "pkg_urdf/obj.urdf": (urdf_text("package://outside/secret.obj"), "does not map"),
        "bad_xml/obj.urdf": ("<robot><link", "malformed URDF XML"),
        "degenerate.obj": ("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "degenerate"),
        "huge_units.obj": (box_obj_text(40.0), "wrong units"),
        "truncated.stl": (None, "cannot parse"),
        "too_big.obj": (good + "# padding\n" * 4000, "over the cap"),
        "mtllib_escape.obj": ("mtllib ../../outside/secret.mtl\nusemtl x\n" + good, "ok"),
    }
    expected = {}
    rng = np.random.default_rng(0)
    for name, (text, outcome) in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if name == "truncated.stl":  # a binary STL header announcing 1000 triangles, then 3 of them
            path.write_bytes(b"\0" * 80 + (1000).to_bytes(4, "little") + b"\1" * 150)
        elif text is None:
            path.write_bytes(rng.integers(0, 256, 300, dtype=np.uint8).tobytes())
        else:
            path.write_text(text)
        if outcome is not None:
            expected[name] = outcome
    os.symlink(outside / "secret.obj", root / "symlink_out.obj")
    expected["symlink_out.obj"] = "outside its root"
    link_dir = root / "link_urdf"
    link_dir.mkdir()
    os.symlink(outside / "secret.obj", link_dir / "box.obj")
    (link_dir / "obj.urdf").write_text(urdf_text("box.obj"))
    expected["link_urdf/obj.urdf"] = "outside its root"
    return expected


def objects_done_at_least(client, job_id: str, count: int, timeout: float = 120.0) -> int:
    """Poll a job until ``count`` objects are done (or ``timeout`` s pass); returns how many are done."""
    import time

    deadline = time.monotonic() + timeout
    while (done := client.status(job_id).progress.objects_done) < count and time.monotonic() < deadline:
        time.sleep(0.05)
    return done


def noisy_scan(mesh, rng, count: int = 20000, noise: float = 0.0005, outlier_fraction: float = 0.02):
    """(n, 3) points of a simulated scan of ``mesh``: surface samples with Gaussian noise (m) plus uniform
    outliers in a box 2 cm around it."""
    from onepiece_dist.core.mesh import sample_surface

    points, _ = sample_surface(mesh, count, rng)
    points = points + rng.normal(0, noise, points.shape)
    outliers = rng.uniform(points.min(axis=0) - 0.02, points.max(axis=0) + 0.02, (int(count * outlier_fraction), 3))
    return np.vstack([points, outliers])


def torus_mesh(major: float = 0.04, minor: float = 0.015):
    import trimesh

    from onepiece_dist.core.mesh import make_mesh

    torus = trimesh.creation.torus(major, minor)
    return make_mesh(torus.vertices, torus.faces, "torus")


def box_slabs(extents: tuple[float, float, float], count: int) -> list[np.ndarray]:
    """The corners (8, 3) of ``count`` boxes that stack along z into one box of ``extents`` centred at the
    origin: convex pieces of a box, as a convex decomposition would give them."""
    half = np.asarray(extents, dtype=np.float64) / 2
    corners = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64) * half
    cuts = np.linspace(-half[2], half[2], count + 1)
    slabs = []
    for low, high in zip(cuts[:-1], cuts[1:], strict=True):
        slab = corners.copy()
        slab[:, 2] = np.where(corners[:, 2] < 0, low, high)
        slabs.append(slab)
    return slabs


def synthetic_labelled_dataset(path: Path, rows: int, points: int = 64, group: str = "assembled/grasps",
                               grid: tuple[int, int, int] = (4, 8, 2), seed: int = 0) -> Path:
    """A complete dataset with ``rows`` labelled grasps in ``group`` (random clouds and codes; labels
    that depend on the clouds, so a network can learn them); ``points=0`` stores no clouds (a code-only set)."""
    from onepiece_dist.store.dataset import ObjectTable, write_dataset
    from onepiece_dist.store.format import grasp_arrays

    rng = np.random.default_rng(seed)
    code_bytes = -(-int(np.prod(grid)) // 8)
    offset = rng.normal(0, 0.01, rows)  # each cloud shifted along the closing axis; held when shifted one way
    cloud = rng.normal(0, 0.01, (rows, max(points, 1), 3))
    cloud[:, :, 1] += offset[:, None]
    arrays = {"success": (offset > 0).astype(np.uint8), "points": cloud.astype(np.float16),
              "quality": rng.random(rows), "code": rng.integers(0, 256, (rows, code_bytes)),
              "patch" if group != "grasps" else "object": np.arange(rows) // 8}
    if not points:
        del arrays["points"]
    attrs = {"grid_shape": list(grid), "code_bytes": code_bytes}
    write_dataset(path, attrs, ObjectTable([], [], np.zeros(0)), {group: grasp_arrays(arrays)})
    return path


def stage_reached(client, job_id: str, stage: str, timeout: float = 300.0) -> bool:
    """Poll a job until its status names ``stage`` (or ``timeout`` s pass)."""
    import time

    deadline = time.monotonic() + timeout
    while client.status(job_id).stage != stage and time.monotonic() < deadline:
        time.sleep(0.05)
    return client.status(job_id).stage == stage


# A study small enough for a test: 4 train objects, 3 held-out, one radius, one budget, 2 seeds.
TINY_STUDY = {"train": "pybullet:random_urdfs[0:4]", "heldout": "pybullet:random_urdfs[500:503]",
              "grasps_per_object": 16, "heldout_grasps": 12, "radii": [0], "budgets": [0.5], "label_trials": 2,
              "points_per_grasp": 64, "targets": {"bootstrap_draws": 200, "ap_draws": 100},
              "training": {"model": "voxel", "steps": 20, "batch_size": 16, "learning_rates": [1e-3, 3e-3],
                           "seeds": 2, "evaluations": 2}}


def comparable_study(result: dict) -> dict:
    """What a study found, without when, how long and what was reused."""
    arms = [{"name": a["name"], "heldout": a["heldout"] | {"seeds": [{k: v for k, v in s.items()
                                                                      if k != "train_seconds"}
                                                                     for s in a["heldout"]["seeds"]]},
             "labelled": a["cost"]["labelled_grasps"], "trials": a["cost"]["label_trials"],
             "bytes": a["cost"]["labelled_bytes"]} for a in result["arms"]]
    return {"arms": arms, "premise": result["premise"], "heldout": result["heldout"], "digest": result["digest"]}
