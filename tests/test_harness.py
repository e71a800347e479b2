"""The suite's own scheduling (tests/conftest.py): Ray tests one at a time on one xdist worker, the rest beside them
at a lower CPU priority, so the Ray group, the suite's critical path, keeps the cores it needs."""

import os

import pytest

from tests.conftest import AUTOGROUP, autogroups_on, starts_ray


def test_every_test_that_starts_ray_is_in_the_one_ray_group(request):
    ray_tests = [item for item in request.session.items if starts_ray(item)]
    if not ray_tests:
        pytest.skip("no ray- or cluster-marked test collected in this session")
    groups = {item.get_closest_marker("xdist_group").args[0] for item in ray_tests
              if item.get_closest_marker("xdist_group")}
    assert groups == {"ray"} and all(item.get_closest_marker("xdist_group") for item in ray_tests)


def test_a_test_beside_the_ray_group_runs_in_its_own_session_at_a_lower_priority():
    if not os.environ.get("PYTEST_XDIST_WORKER") or os.geteuid() != 0:
        pytest.skip("lowered only in an xdist worker that may raise it again (root)")
    if autogroups_on():
        assert os.getsid(0) == os.getpid() and AUTOGROUP.read_text().split()[-1] == "10"
    else:
        assert os.getpriority(os.PRIO_PROCESS, 0) == 10
