import numpy as np
import pytest

from onepiece_dist.service.local import run_local
from onepiece_dist.service.ray_runner import ExtractionWorker, run_ray
from onepiece_dist.store import open_dataset

pytestmark = [pytest.mark.ray, pytest.mark.slow]


def test_worker_class_runs_without_ray(spec_factory):
    spec = spec_factory(objects="primitives[0:1]")
    result = ExtractionWorker(spec).extract(__import__("onepiece_dist").objects.resolve_source(spec.objects)[0], 0)
    assert result.status == "ok" and result.grasps > 0


def test_ray_runner_matches_the_in_process_runner(spec_factory, tmp_path):
    import ray

    a = spec_factory(output=str(tmp_path / "a.zarr"), objects="primitives[0:4]")
    b = spec_factory(output=str(tmp_path / "b.zarr"), objects="primitives[0:4]")
    try:
        status = run_ray(a, workers=2)
    finally:
        ray.shutdown()
    run_local(b)
    assert status.state == "succeeded" and status.progress.objects_done == 4
    da, db = open_dataset(a.output), open_dataset(b.output)
    for name in ("grasps/code", "grasps/pose", "grasps/object", "unique/code", "unique/count"):
        assert np.array_equal(da[name], db[name]), name
