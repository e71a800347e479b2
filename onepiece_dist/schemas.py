"""JSON Schemas of the public models, written to ``schemas/`` (a test fails when they drift)."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.objects.supplement import SupplementReport, SupplementSpec
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec
from onepiece_dist.store.layout import DatasetAttributes

MODELS = {"job_spec": JobSpec, "job_status": JobStatus, "dataset_layout": DatasetAttributes,
          "supplement_spec": SupplementSpec, "supplement_report": SupplementReport}


def render_schemas() -> dict[str, str]:
    """File name -> JSON text for each public model."""
    return {f"{name}.schema.json": json.dumps(model.model_json_schema(), indent=2, sort_keys=True) + "\n"
            for name, model in MODELS.items()}


def write_schemas(folder: str | Path) -> list[Path]:
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in render_schemas().items():
        (folder / name).write_text(text)
        written.append(folder / name)
    return written
