"""The docs' Python examples as written: every name they import from the package exists, and the planning
example runs on a cloud (its file names put in place)."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([*ROOT.glob("docs/**/*.md"), ROOT / "README.md"])


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), re.S)


def test_every_name_the_docs_examples_import_from_the_package_exists():
    imported = []
    for page in PAGES:
        for block in python_blocks(page):
            for node in ast.walk(ast.parse(block)):  # a block that does not parse fails here
                if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("onepiece_dist"):
                    imported += [(page.name, node.module, alias.name) for alias in node.names]
    missing = [(page, module, name) for page, module, name in imported
               if not hasattr(importlib.import_module(module), name)]
    assert len(imported) >= 5 and missing == []  # none found would mean the blocks were not read


@pytest.mark.sim
def test_the_planning_pages_python_example_runs_as_written(tmp_path, monkeypatch):
    from onepiece_dist.plan.shipped import shipped_network
    from tests.test_objects_apart import APART
    from tests.test_plan import _floor
    from tests.test_shape_check import seen_box

    example = next(b for b in python_blocks(ROOT / "docs" / "planning.md") if 'read_cloud("cloud.ply"' in b)
    cloud = np.vstack([seen_box() + [0.0, 0.0, 0.0], seen_box() + APART, _floor(0.0)])
    np.save(tmp_path / "cloud.npy", cloud)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(example.replace('"cloud.ply"', '"cloud.npy"').replace('"best.pt"', repr(str(shipped_network()))),
         namespace)
    plan = namespace["plan"]
    assert len(plan.grasps) == 10 and plan.grasps[0].held is not None
    assert (tmp_path / "grasps" / "grasps.json").is_file()
