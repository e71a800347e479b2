import pytest

from tests.factories import small_spec


@pytest.fixture
def spec_factory(tmp_path):
    def make(**overrides):
        return small_spec(tmp_path, **overrides)

    return make


@pytest.fixture(scope="module")
def ray_session():
    """An embedded, loopback-only Ray shared by a test module."""
    import ray

    from onepiece_dist.service.ray_env import connect

    connect(None, num_cpus=2)
    yield ray
    ray.shutdown()
