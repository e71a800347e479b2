"""The shipped planner under a depth camera's noise (docs/picks.md): the pick benchmark renders exact depth; a real
depth camera's is noisy (about 1-2 mm at 0.5-0.8 m for a structured-light or stereo camera, more at range and on
dark or shiny surfaces). The household and unseen sets judged as the pick benchmark judges them (8 views an object,
the shipped network, the planner's defaults, beside top-down), the camera's every pixel moved along its ray by
Gaussian noise of NOISES (m: `onepiece pick` spec ``camera.depth_noise``); each paired over objects against
BASELINE, noise of a micrometre: the same objects, settles and cameras, and the same draws after them (a view's
noise is drawn from its stream, so a run without noise would plan and check from other draws, a difference of its
own of about 4 points at one draw a view).

With the planner's ``denoise`` (PlanSpec, core.cloud.denoise: the noise measured under the support plane and
taken out of the view) at ``auto``, its default, and at ``none``, each level paired against the other too.

    .venv/bin/python -m benchmarks.experiments.pick_depth_noise [--noises 0.000001,0.001,0.002,0.004]
        [--denoise auto|none] [--gripper panda]

Results: benchmarks/results/pick_depth_noise.json (a level run again replaces its own results), rendered into
docs/picks.md; with --gripper panda (the network shipped for the Franka hand planning, every grasp executed by that
hand) pick_depth_noise_panda.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date
from pathlib import Path

from benchmarks.experiments.pick_clutter import hand_record
from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.pages.pick_sets import paired_first_attempts

RESULTS = HERE / "results" / "pick_depth_noise.json"
BASELINE = 1e-6  # m: noise that moves no point to matter, drawn as every level's is
NOISES = (BASELINE, 0.001, 0.002, 0.004)
SETS, METHODS = ("household", "unseen"), ("network", "top_down")


def level(noise: float, denoise: str, gripper: str | None = None, network=None, folder=None,
          views: int | None = None, flying_pixels: float = 0.0, drop_flying: float = 0.0, first_view: int = 0
          ) -> dict:
    """Both sets judged with ``noise`` (m) on the camera's depth, the planner's ``denoise`` as given (``gripper``:
    a preset, its shipped network planning unless ``network``, a checkpoint, is given; runs kept under ``folder``,
    by default this benchmark's; ``views`` an object from ``first_view``, by default the pick benchmark's; a
    ``flying_pixels`` share of the pixels at the depth's edges mixed across them: CameraSpec.flying_pixels; the
    planner dropping flying pixels at ``drop_flying``: PlanSpec.drop_flying)."""
    from benchmarks.experiments.pick_clutter import shipped_for
    from benchmarks.experiments.picks import ATTEMPTS, VIEWS, sets
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.specs.plan import CameraSpec, PickSpec, PlanSpec

    judged = []
    for name in SETS:
        objects, source = sets()[name]
        shipped, hand = shipped_for(gripper)
        runs = folder or ROOT / "data" / ("pick_depth_noise" + (f"_{gripper}" if gripper else ""))
        spec = PickSpec(objects=objects(), checkpoint=str(network or shipped), gripper=hand, views=views or VIEWS,
                        first_view=first_view, attempts=ATTEMPTS, pictures=0, methods=METHODS,
                        camera=CameraSpec(depth_noise=noise, flying_pixels=flying_pixels),
                        plan=PlanSpec(denoise=denoise, drop_flying=drop_flying),
                        output=str(runs / f"{noise:g}_{denoise}" / name))
        start = time.perf_counter()
        report = run_picks(spec)
        judged.append({**report.to_json(), "name": name, "source": source,
                       "seconds": round(time.perf_counter() - start, 1)})
        print(noise, denoise, name, {m["method"]: m["first_attempt"] for m in judged[-1]["methods"]}, flush=True)
    return {"noise": noise, "denoise": denoise, "sets": judged,
            "network_vs_top_down": paired_first_attempts(judged, judged, "network", "top_down")}


def results_path(gripper: str | None) -> Path:
    """Where this benchmark keeps the levels of ``gripper`` (a preset; None: the default job's gripper)."""
    return RESULTS if gripper is None else RESULTS.with_name(f"pick_depth_noise_{gripper}.json")


def against_baseline(levels: list[dict]) -> list[dict]:
    """``levels`` each with its choosers paired over objects against the BASELINE level's of the same denoise
    (where it is run), and the network with ``denoise`` auto against none at the same noise (where both are)."""
    def found(noise: float, denoise: str) -> dict | None:
        return next((lv for lv in levels if (lv["noise"], lv["denoise"]) == (noise, denoise)), None)

    out = []
    for lv in levels:
        base, other = found(BASELINE, lv["denoise"]), found(lv["noise"], "none")
        extra = {}
        if base is not None and base is not lv:
            extra["versus_baseline"] = {m: paired_first_attempts(lv["sets"], base["sets"], m) for m in METHODS}
        if lv["denoise"] == "auto" and other is not None:
            extra["versus_none"] = paired_first_attempts(lv["sets"], other["sets"], "network")
        out.append({**{k: v for k, v in lv.items() if k not in ("versus_baseline", "versus_none")}, **extra})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noises", default=",".join(f"{n:g}" for n in NOISES))
    parser.add_argument("--denoise", choices=("auto", "none"), default="auto")
    parser.add_argument("--gripper", choices=("panda",), default=None,
                        help="the preset whose shipped network plans and whose hand executes")
    args = parser.parse_args()
    path = results_path(args.gripper)
    kept = json.loads(path.read_text())["levels"] if path.is_file() else []
    command = ".venv/bin/python -m benchmarks.experiments.pick_depth_noise" + (f" --gripper {args.gripper}"
                                                                               if args.gripper else "")
    out = {"command": command, "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", **hand_record(args.gripper),
           "levels": kept}
    for noise in (float(n) for n in args.noises.split(",")):
        made = level(noise, args.denoise, args.gripper)
        kept = [lv for lv in out["levels"] if (lv["noise"], lv["denoise"]) != (noise, args.denoise)]
        out["levels"] = against_baseline(sorted([*kept, made], key=lambda lv: (lv["denoise"], lv["noise"])))
        path.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps([{k: lv.get(k) for k in ("noise", "denoise", "versus_baseline", "versus_none")}
                      for lv in out["levels"]], indent=1))


if __name__ == "__main__":
    main()
