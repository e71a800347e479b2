import pytest

from tests.factories import small_spec


@pytest.fixture
def spec_factory(tmp_path):
    def make(**overrides):
        return small_spec(tmp_path, **overrides)

    return make
