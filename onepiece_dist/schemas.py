"""JSON Schemas of the public models, written to ``schemas/`` (a test fails when they drift)."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.objects.supplement import SupplementReport, SupplementSpec
from onepiece_dist.service.status import JobStatus
from onepiece_dist.spec import JobSpec
from onepiece_dist.store.layout import ARRAYS, DatasetAttributes

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


TABLE_START, TABLE_END = "<!-- arrays: from store/layout.py by `onepiece schema` -->", "<!-- end of arrays -->"


def render_array_table() -> str:
    """The Markdown table of every array of the format (store/layout.py), as docs/dataset_format.md holds it."""
    rows = [f"| `{path}` | {dtype} | {shape} | {meaning} |" for path, dtype, shape, meaning in ARRAYS]
    return "\n".join([TABLE_START, "| array | dtype | shape | meaning |", "| --- | --- | --- | --- |", *rows,
                      TABLE_END])


def refresh_format_page(page: Path) -> bool:
    """Replace the array table of the format page with the rendered one. Returns whether the page changed."""
    text = page.read_text()
    start, end = text.index(TABLE_START), text.index(TABLE_END) + len(TABLE_END)
    updated = text[:start] + render_array_table() + text[end:]
    page.write_text(updated)
    return updated != text
