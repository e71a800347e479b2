"""The study wing: does ONE PIECE pay on *your* objects, and what is the cheapest plan that labels as well as
labelling everything? Arms A, B (per similar-shape radius) and R (label budgets), held-out evaluation, the
statistics, the decision and the pages (docs/study.md).

    from onepiece_dist.study import StudySpec, run_study
    result = run_study(StudySpec(train="meshes/train", heldout="meshes/heldout"), "my-study")
    print(result.decision.cheapest)

Names load lazily: the spec and the result need only pydantic; running a study needs the service (Ray, pybullet,
torch).
"""

from __future__ import annotations

import importlib

_NAMES = {"StudySpec": "spec", "StudyTargets": "spec", "StudyTraining": "spec", "load_study_spec": "spec",
          "StudyResult": "result", "run_study": "runner", "report_study": "runner", "Where": "runner"}
__all__ = sorted(_NAMES)


def __getattr__(name: str):
    if name not in _NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
