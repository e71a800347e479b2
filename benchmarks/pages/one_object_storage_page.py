"""docs/one_object_storage.md, rendered from benchmarks/results/one_object_storage.json
(benchmarks/experiments/one_object_storage.py measures it)."""

from __future__ import annotations

from pathlib import Path


def mb(count: int | None) -> str:
    return "-" if count is None else f"{count / 1e6:.1f} MB"


def page_text(out: dict) -> str:
    a, met = out["a"], out["met"]
    word = {True: "met", False: "not met"}
    lines = ["# The one object on disk: format 2 at the paper's size", "",
             f"Command: `{out['command']}` ({out['date']}, {out['machine']}). Rendered from "
             "benchmarks/results/one_object_storage.json by benchmarks/pages/one_object_storage_page.py.", "",
             "Format 2 keeps each source object's surface points once (`assembled/source_points`) and derives every "
             "patch's points and the one object's dense cloud from them; format 1 stored that cloud twice "
             "(`assembled/points`, `assembled/patch_points`). The delivered dataset is what a trainer needs: for B "
             "the one object and its labelled grasps (everything but the extraction records `grasps/` and "
             "`unique/`), for A its labelled grasps (`grasps/`) and the objects table; the objects' meshes are "
             "references in both.", "",
             f"A (format unchanged, the paper experiment's): whole {mb(a['whole_bytes'])}, delivered "
             f"{mb(a['delivered_bytes'])}.", "",
             *(["**--quick: 4 objects x 40 candidates against the full-size A, a smoke test of the script; its "
                "ratios and targets mean nothing.**", ""] if out["quick"] else []),
             "| arm | patches | whole, format 1 | whole, format 2 | whole A/B | delivered | delivered A/B | "
             "assemble s |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in out["arms"]:
        lines.append(f"| {r['arm']} | {r['patches']:,} | {mb(r['format1_whole_bytes'])} | {mb(r['whole_bytes'])} | "
                     f"{r['whole_ratio']:.2f}x | {mb(r['delivered_bytes'])} | {r['delivered_ratio']:.2f}x | "
                     f"{r['assemble_seconds']:.0f} |")
    lines += ["", "## Targets", "",
              f"- Delivered A/B at B r2 >= {out['targets']['delivered_r2']}x: {word[met['delivered_r2']]}.",
              f"- Delivered A/B at B r0 >= {out['targets']['delivered_r0']}x: {word[met['delivered_r0']]}.",
              f"- B r0's whole store no larger than A's: {word[met['whole_r0_no_larger_than_a']]}.", "",
              "## Where the bytes are (B r0's store)", "",
              "| group | bytes |", "| --- | ---: |"]
    r0 = out["arms"][0]
    for name, size in sorted(r0["groups"].items(), key=lambda item: -item[1])[:12]:
        lines.append(f"| `{name}` | {mb(size)} |")
    return "\n".join(lines) + "\n"



def write_page(out: dict, path: Path) -> None:
    path.write_text(page_text(out))
