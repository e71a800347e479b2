"""JSON Schemas of the public models, written to ``schemas/`` (a test fails when they drift)."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.job.status import JobStatus
from onepiece_dist.objects.supplement import SupplementReport, SupplementSpec
from onepiece_dist.specs.job import JobSpec
from onepiece_dist.specs.plan import PickLabelSpec, PickSpec, PlanSpec
from onepiece_dist.store.layout import ARRAYS, DatasetAttributes
from onepiece_dist.study.pick_study.result import PickStudyResult
from onepiece_dist.study.result import StudyResult
from onepiece_dist.study.spec import StudySpec

MODELS = {"job_spec": JobSpec, "job_status": JobStatus, "dataset_layout": DatasetAttributes,
          "supplement_spec": SupplementSpec, "supplement_report": SupplementReport, "study_spec": StudySpec,
          "study_result": StudyResult, "plan_spec": PlanSpec, "pick_spec": PickSpec,
          "pick_label_spec": PickLabelSpec, "pick_study_result": PickStudyResult}


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


ATTRS_START = "<!-- attributes: from store/layout.py by `onepiece schema` -->"
ATTRS_END = "<!-- end of attributes -->"


def render_attribute_table() -> str:
    """The Markdown table of every root attribute (DatasetAttributes), as docs/dataset_format.md holds it."""
    rows = [f"| `{name}` | {'no' if field.default is None else 'yes'} | {field.description} |"
            for name, field in DatasetAttributes.model_fields.items()]
    return "\n".join([ATTRS_START, "| attribute | always | meaning |", "| --- | --- | --- |", *rows, ATTRS_END])


def render_format_page(text: str) -> str:
    """The format page's text with both generated tables (arrays, attributes) rendered."""
    for start_mark, end_mark, table in ((TABLE_START, TABLE_END, render_array_table()),
                                        (ATTRS_START, ATTRS_END, render_attribute_table())):
        start, end = text.index(start_mark), text.index(end_mark) + len(end_mark)
        text = text[:start] + table + text[end:]
    return text


def refresh_format_page(page: Path) -> bool:
    """Render the generated tables of the format page. Returns whether the page changed."""
    text = page.read_text()
    updated = render_format_page(text)
    page.write_text(updated)
    return updated != text


def render_example_job() -> str:
    """examples/job.yaml: every JobSpec field with its default value and, above it, what it means."""
    lines = ["# Every field of a job spec, at its default, with what it means (rendered from the JobSpec model by",
             "# `onepiece schema`; a test keeps them in step). Copy it, keep the fields you change, and run:",
             "#   onepiece run job.yaml   |   onepiece submit job.yaml --address http://127.0.0.1:8265 --wait",
             "# The machine-readable contract: schemas/job_spec.schema.json.", ""]
    return "\n".join(lines + _model_lines(JobSpec(), 0)) + "\n"


def _model_lines(model, depth: int) -> list[str]:
    import yaml
    from pydantic import BaseModel

    pad, lines = "  " * depth, []
    for name, field in type(model).model_fields.items():
        value = getattr(model, name)
        nested = isinstance(value, BaseModel)
        about = field.description or ((type(value).__doc__ or "").strip().splitlines()[0] if nested else "")
        lines += [f"{pad}# {line}" for line in _wrap(about or "", 116 - len(pad))]
        if nested:
            lines += [f"{pad}{name}:", *_model_lines(value, depth + 1)]
        else:
            dumped = yaml.safe_dump({name: list(value) if isinstance(value, tuple) else value},
                                    default_flow_style=True, width=1000).strip()
            lines.append(pad + dumped.removeprefix("{").removesuffix("}"))
    return lines


def _wrap(text: str, width: int) -> list[str]:
    import textwrap

    return textwrap.wrap(text, width) if text else []
