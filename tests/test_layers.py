import subprocess
import sys
from pathlib import Path

import pytest

from onepiece_dist.schemas import render_schemas

ROOT = Path(__file__).resolve().parents[1]


def test_core_imports_no_simulator_store_ray_or_torch():
    code = ("import sys, onepiece_dist.core.frames, onepiece_dist.core.voxel, onepiece_dist.core.dedup, "
            "onepiece_dist.core.mesh, onepiece_dist.core.sampling; "
            "print(sorted(m for m in ('pybullet', 'zarr', 'ray', 'torch') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("name", sorted(render_schemas()))
def test_committed_schemas_match_models(name):
    committed = (ROOT / "schemas" / name).read_text()
    assert committed == render_schemas()[name], f"schemas/{name} drifted: run `onepiece schema`"
