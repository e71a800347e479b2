"""closure.enabled: every extracted grasp and every grasp labelled on the one object carries its force-closure
level, epsilon and contact state, as core.closure gives them on the geometry the grasp was made on."""

import numpy as np
import pytest

from onepiece_dist.core.closure import CONTACT_STATES, closure_arrays
from onepiece_dist.runtime.local import run_local
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.store import open_dataset

NAMES = ("fc_mu", "fc_epsilon", "fc_contacts")


@pytest.mark.sim
@pytest.mark.slow
def test_a_job_with_closure_scores_its_grasps_on_the_sources_and_the_patches(tmp_path, record_figure):
    from onepiece_dist.objects import load_object
    from onepiece_dist.objects.sources import resolve_source

    spec = JobSpec(objects="pybullet:named[3:4]+pybullet:random_urdfs[0:2]", grasps_per_object=24,
                   output=str(tmp_path / "fc.zarr"), stages=("ingest", "extract", "dedup", "assemble", "label"),
                   closure={"enabled": True}, sim={"perturbations_per_patch": 2})
    run_local(spec)
    ds = open_dataset(spec.output)
    for group in ("grasps", "assembled/grasps"):
        rows = len(ds[f"{group}/code"])
        mu, eps, state = (ds[f"{group}/{name}"] for name in NAMES)
        assert len(mu) == len(eps) == len(state) == rows > 0
        assert not np.isnan(mu).any() and not np.isnan(eps).any()
        assert set(np.unique(mu)) <= {*np.float32(spec.closure.levels), np.float32(np.inf)}
        assert set(np.unique(state)) <= {0, 1, 2}
        assert np.all(eps[state != 0] == 0) and np.all(np.isinf(mu[state != 0])) and np.isfinite(mu).any()
    mesh = load_object(resolve_source("pybullet:named[3:4]")[0], spec).mesh
    first = int(ds["objects/grasp_count"][0])
    again = closure_arrays(mesh.vertices, mesh.faces, ds["grasps/pose"][:first].astype(np.float64), spec)
    assert np.mean(np.float32(again["fc_mu"]) == ds["grasps/fc_mu"][:first]) >= 0.9  # poses are stored in float32
    plain = JobSpec(objects="primitives[0:1]", grasps_per_object=8, output=str(tmp_path / "plain.zarr"),
                    stages=("ingest", "extract", "dedup"))
    run_local(plain)
    assert not any(open_dataset(plain.output).has(f"grasps/{name}") for name in NAMES)
    src, one = ds["grasps/fc_mu"], ds["assembled/grasps/fc_mu"]
    states = dict(zip(CONTACT_STATES, np.bincount(ds["grasps/fc_contacts"], minlength=3).tolist(), strict=True))
    record_figure(f"in force closure at graspnetAPI's sweep: {np.isfinite(src).mean():.0%} of {len(src)} source "
                  f"grasps, {np.isfinite(one).mean():.0%} of {len(one)} one-object grasps; contact states {states}")


def test_a_label_other_than_physics_needs_the_scores_and_says_so():
    from onepiece_dist.errors import SpecError
    from onepiece_dist.specs.job import parse_job_spec

    with pytest.raises(SpecError, match="closure.label"):
        parse_job_spec({"closure": {"label": "force_closure"}})
    assert parse_job_spec({"closure": {"label": "both", "enabled": True}}).closure.good_mu == 0.4


@pytest.mark.sim
@pytest.mark.slow
def test_under_the_force_closure_label_success_is_fc_mu_at_good_mu_and_transfer_uses_it(tmp_path, record_figure):
    """With closure.label force_closure and no sim.label, the sources are labelled without lifting anything; on
    the one object success is the patches' force closure and the trials' outcome stays as physics_success; the
    label-transfer report compares force-closure labels on both sides."""
    spec = JobSpec(objects="pybullet:named[3:4]+pybullet:random_urdfs[0:2]", grasps_per_object=24,
                   output=str(tmp_path / "fc.zarr"), stages=("ingest", "extract", "dedup", "assemble", "label"),
                   closure={"enabled": True, "label": "force_closure"},
                   sim={"perturbations_per_patch": 2, "transfer_codes": 20})
    run_local(spec)
    ds = open_dataset(spec.output)
    for group in ("grasps", "assembled/grasps"):
        assert np.array_equal(ds[f"{group}/success"], (ds[f"{group}/fc_mu"] <= 0.4 + 1e-6).astype(np.uint8))
    assert not ds.has("grasps/physics_success") and ds.has("assembled/grasps/physics_success")
    physics, label = ds["assembled/grasps/physics_success"], ds["assembled/grasps/success"]
    assert 0 < label.mean() < 1 and not np.array_equal(physics, label)
    transfer = ds.attrs["assembly_labels"]["transfer"]
    assert transfer["codes"] > 0 and transfer["patch_vs_source"]["pairs"] > 0
    record_figure(f"force-closure label (mu <= 0.4): {ds['grasps/success'].mean():.0%} of source grasps, "
                  f"{label.mean():.0%} on the one object (physics there {physics.mean():.0%}, the two agree "
                  f"{np.mean(physics == label):.0%}); patch vs source agreement "
                  f"{transfer['patch_vs_source']['success_agreement']}, same code "
                  f"{transfer['same_code']['success_agreement']}, random pairs "
                  f"{transfer['random_pairs']['success_agreement']}")
