"""pytest plugin (``-p tests.pinned_libm`` in pyproject.toml): the suite starts itself again with glibc's math
functions pinned, as the ``onepiece`` command does (``onepiece_dist.sim.libm``). A ``-p`` plugin loads before
pytest captures the terminal, so the restarted run still writes to it; a conftest would load too late."""

from onepiece_dist.sim.libm import restart_pinned

restart_pinned()
