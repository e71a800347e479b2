"""docs/decomposition.md from the committed side-by-side of VHACD and CoACD (results/decomposition.json,
benchmarks/experiments/decomposition.py) and a worker's fixed costs (results/worker_start.json,
benchmarks/speed/bench_worker_start.py): the page's figures are rendered, never typed."""

from __future__ import annotations

from benchmarks.pages.committed import met

LABELS = {"vhacd": "VHACD (default, 50k voxels)", "coacd": "CoACD (threshold 0.05)",
          "vhacd_fine": "VHACD (1M voxels)", "reference": "reference: CoACD (threshold 0.02)"}


def _pct(x: float) -> str:
    return f"{100 * x:.0f}%"


def worker_start_section(r: dict) -> list[str]:
    """VHACD's served child against a child per object, open3d without plotly against its plain import."""
    v, o = r["vhacd"], r["open3d_import"]
    return [
        "## A worker's fixed costs: VHACD's child and open3d's import", "",
        f"`{r['command']}`, {r['date']}, {r['machine']}.", "",
        f"VHACD runs in a child process (a crash on a mesh must not take the worker down). One child now serves a "
        f"process's every object; before, each object started its own. On {v['objects']} objects ({r['source']}): "
        f"{v['fresh_child']['cpu_seconds']:.2f} CPU-s with a child per object, {v['served_child']['cpu_seconds']:.2f} "
        f"with one served child, **{v['cpu_ratio']:.2f}x** less (target {r['target']}x: "
        f"{met(v['cpu_ratio'], r['target'])}), the same bytes for every object.", "",
        f"open3d's own import loads plotly and dash for its plotly drawing, which nothing here uses; the package "
        f"imports open3d without them (`core.raycast.import_open3d`). A fresh process importing open3d (median of "
        f"{o['processes']}): {o['plain_cpu_seconds']:.2f} CPU-s plainly, {o['without_plotly_cpu_seconds']:.2f} "
        f"without plotly, **{o['cpu_ratio']:.2f}x** less (target {r['target']}x: "
        f"{met(o['cpu_ratio'], r['target'])}). Every worker that samples grasps pays it once."]


def render(result: dict, worker_start: dict | None = None) -> str:
    summary = result["summary"]
    rows = [f"| {LABELS[name]} | {summary[name]['seconds_median']:.2f} | {summary[name]['seconds_total']:.0f} | "
            f"{_pct(summary[name]['agreement'])} |" for name in LABELS]
    objects = [f"| {r['name']} | {r['faces']} | " + " | ".join(
        f"{r['methods'][n]['pieces']} / {r['methods'][n]['seconds']:.1f} s / {_pct(r['methods'][n]['agreement'])}"
        for n in LABELS) + f" | {_pct(r['label_repeatability'])} |" for r in result["objects"]]
    v, c, repeat = summary["vhacd"], summary["coacd"], summary["label_repeatability"]
    return "\n".join([
        "# Convex decomposition: VHACD and CoACD side by side",
        "",
        "<!-- rendered by benchmarks/pages/decomposition_page.py from benchmarks/results/decomposition.json; do not "
        "edit -->",
        "",
        f"Over {len(result['objects'])} objects (robosuite's household meshes and procedural random_urdfs), "
        f"{result['grasps_per_object']} candidates each, {result['protocol']}: CoACD's labels agree with the "
        f"converged reference on **{_pct(c['agreement'])}** of the grasps, VHACD's on **{_pct(v['agreement'])}**; "
        f"CoACD takes {c['seconds_median']:.2f} s per object (median), VHACD {v['seconds_median']:.2f} s. Every "
        "decomposition met the same perturbation draws per grasp, so its disagreement with the reference is its "
        f"geometry's alone; for scale, the label executed again with other draws on the reference's pieces "
        f"repeats on {_pct(repeat)}.",
        "",
        "Command: `python -m benchmarks.experiments.decomposition`; a job chooses with "
        "`sim.collision: vhacd | coacd | hull` (CoACD is the extra `decompose`).",
        "",
        "| decomposition | seconds per object (median) | seconds in all | label agreement with the reference |",
        "| --- | --- | --- | --- |",
        *rows,
        "",
        "Per object: pieces / seconds / agreement.",
        "",
        "| object | faces | " + " | ".join(LABELS.values()) + " | label repeatability |",
        "| --- | --- | " + " | ".join("---" for _ in LABELS) + " | --- |",
        *objects,
        "",
        *([*worker_start_section(worker_start), ""] if worker_start else [])])
