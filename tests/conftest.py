import fcntl
import hashlib
import json
import os
import platform
from datetime import date
from pathlib import Path

import pytest

from tests.factories import small_spec

FIGURES = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "reliability.json"


def pytest_addoption(parser):
    parser.addoption("--record-figures", action="store_true",
                     help="write the figures the reliability tests measure to benchmarks/results/reliability.json "
                          "(docs/reliability.md renders them: python -m benchmarks.pages.report)")


def pytest_configure(config):
    config.recorded_figures = {}


@pytest.fixture
def record_figure(request):
    """``record_figure(text)``: the figure this test measured, in words; kept only with ``--record-figures``.
    Call it after the test's assertions, so that only a passing test records."""

    def record(text: str) -> None:
        test_id = request.node.nodeid.removeprefix("tests/")
        request.config.recorded_figures[test_id] = {"figure": text, "date": str(date.today()),
                                                    "machine": f"{platform.machine()}, {os.cpu_count()} cores"}

    return record


def pytest_sessionfinish(session):
    """Merge this process's figures into the file, under a lock: each xdist worker records its own tests'."""
    figures = session.config.recorded_figures
    if session.config.getoption("--record-figures") and figures:
        folder = os.open(FIGURES.parent, os.O_RDONLY)  # the lock: the results folder, no file of its own
        try:
            fcntl.flock(folder, fcntl.LOCK_EX)
            old = json.loads(FIGURES.read_text()) if FIGURES.exists() else {"figures": {}}
            old["command"] = "scripts/dev test --record-figures"
            old["figures"] = dict(sorted({**old["figures"], **figures}.items()))
            FIGURES.write_text(json.dumps(old, indent=2) + "\n")
        finally:
            os.close(folder)  # releases the lock


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Tests that start Ray (marked ray or cluster) run one at a time, on one worker, as they would alone: run
    beside each other on 2 cores, the cluster's Jobs API took over 120 s to start a job's driver."""
    for item in items:
        if starts_ray(item):
            item.add_marker(pytest.mark.xdist_group("ray"))


def starts_ray(item) -> bool:
    return bool(item.get_closest_marker("ray") or item.get_closest_marker("cluster"))


BESIDE_RAY_NICENESS = 10  # CPU share of work at nice 10 against work at 0: about a tenth
AUTOGROUP = Path("/proc/self/autogroup")  # Linux's per-session scheduling group, where sched_autogroup is on
AUTOGROUP_ON = Path("/proc/sys/kernel/sched_autogroup_enabled")


def autogroups_on() -> bool:
    return AUTOGROUP_ON.exists() and AUTOGROUP_ON.read_text().strip() == "1"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Under xdist, a test outside the Ray group runs at a lower CPU priority than the Ray group. The Ray group runs
    its tests one at a time on one worker and is the suite's critical path, and it leaves a core idle much of the
    time (Ray starting, jobs waiting on actors): the other worker's tests fill that idle time instead of taking
    half of both cores. Where this user may raise the priority again after the test (root); else nothing changes."""
    lower = (os.environ.get("PYTEST_XDIST_WORKER") and not item.get_closest_marker("xdist_group")
             and os.geteuid() == 0 and _priority_of_own(BESIDE_RAY_NICENESS))
    try:
        yield
    finally:
        if lower:
            _priority_of_own(0)


def _priority_of_own(niceness: int) -> bool:
    """This worker's work (its threads and the processes it starts) at ``niceness``. With autogroups on, the
    worker first leaves pytest's session for its own and sets the niceness of that session's group (measured
    here: 554 and 509 s for the suite against 630 and 634 s; setting each thread's niceness within pytest's
    session instead gave 610 and 654 s); else it sets each of its threads'. False where it could not."""
    if autogroups_on():
        if os.getsid(0) != os.getpid():
            try:
                os.setsid()
            except OSError:
                return False  # a process group leader: its group may hold the Ray group's worker too
        AUTOGROUP.write_text(str(niceness))
        return True
    if not Path("/proc/self/task").is_dir():
        return False  # not Linux: left as it is
    for tid in os.listdir("/proc/self/task"):
        try:
            os.setpriority(os.PRIO_PROCESS, int(tid), niceness)
        except ProcessLookupError:
            pass  # a thread that ended meanwhile
    return True


@pytest.fixture
def spec_factory(tmp_path):
    def make(**overrides):
        return small_spec(tmp_path, **overrides)

    return make


@pytest.fixture(scope="session")
def fault_free(tmp_path_factory):
    """``fault_free(spec)``: the folder of ``spec``'s dataset run in-process, without faults, once per suite run for
    each spec (its output left out); the reference that the faulted runs of that spec must equal. xdist's workers
    share it: the datasets lie in the run's temporary folder, each made under a lock of its own, so a worker that
    asks for one another worker is making waits for it instead of making it again (a test only reads it). Its
    objects are decomposed in the user's cache, as a local run's are (runtime.local.with_user_decompositions)."""
    from onepiece_dist.runtime.local import run_local, with_user_decompositions

    base = tmp_path_factory.getbasetemp()
    shared = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "fault-free"  # this run's only
    shared.mkdir(parents=True, exist_ok=True)

    def reference(spec) -> str:
        name = hashlib.blake2b(spec.model_dump_json(exclude={"output"}).encode(), digest_size=10).hexdigest()
        output, done = shared / f"{name}.zarr", shared / f"{name}.done"
        lock = os.open(shared / f"{name}.lock", os.O_CREAT | os.O_RDWR)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not done.exists():
                run_local(with_user_decompositions(spec).model_copy(update={"output": str(output)}))
                done.touch()
            return str(output)
        finally:
            os.close(lock)  # releases the lock

    return reference


@pytest.fixture(scope="module")
def ray_session():
    """An embedded, loopback-only Ray shared by a test module."""
    import ray

    from onepiece_dist.runtime.ray_env import connect

    connect(None, num_cpus=2)
    yield ray
    ray.shutdown()
