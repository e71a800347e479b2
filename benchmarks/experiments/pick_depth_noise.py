"""The shipped planner under a depth camera's noise (docs/picks.md): the pick benchmark renders exact depth; a real
depth camera's is noisy (about 1-2 mm at 0.5-0.8 m for a structured-light or stereo camera, more at range and on
dark or shiny surfaces). The household and unseen sets judged as the pick benchmark judges them (8 views an object,
the shipped network, the planner's defaults, beside top-down), the camera's every pixel moved along its ray by
Gaussian noise of NOISES (m: `onepiece pick` spec ``camera.depth_noise``); each paired over objects against the
committed benchmark's run without noise (results/picks.json: the same objects, settles and cameras).

    .venv/bin/python -m benchmarks.experiments.pick_depth_noise [--noises 0.001,0.002,0.004]

Results: benchmarks/results/pick_depth_noise.json (a level run again replaces its own results), rendered into
docs/picks.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from datetime import date

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.pages.pick_sets import paired_first_attempts

RESULTS = HERE / "results" / "pick_depth_noise.json"
NOISES = (0.001, 0.002, 0.004)
SETS, METHODS = ("household", "unseen"), ("network", "top_down")


def level(noise: float, clean: list[dict]) -> dict:
    """Both sets judged with ``noise`` (m) on the camera's depth, and paired against ``clean`` (the benchmark's
    sets without noise), per chooser."""
    from benchmarks.experiments.picks import ATTEMPTS, VIEWS, sets
    from onepiece_dist.picks.runner import run_picks
    from onepiece_dist.plan.shipped import NETWORK
    from onepiece_dist.specs.plan import CameraSpec, PickSpec

    judged = []
    for name in SETS:
        objects, source = sets()[name]
        spec = PickSpec(objects=objects(), checkpoint=str(NETWORK), views=VIEWS, attempts=ATTEMPTS, pictures=0,
                        methods=METHODS, camera=CameraSpec(depth_noise=noise),
                        output=str(ROOT / "data" / "pick_depth_noise" / f"{noise:g}" / name))
        start = time.perf_counter()
        report = run_picks(spec)
        judged.append({**report.to_json(), "name": name, "source": source,
                       "seconds": round(time.perf_counter() - start, 1)})
        print(noise, name, {m["method"]: m["first_attempt"] for m in judged[-1]["methods"]}, flush=True)
    before = [s for s in clean if s["name"] in SETS]
    return {"noise": noise, "sets": judged,
            "versus_clean": {m: paired_first_attempts(judged, before, m) for m in METHODS},
            "network_vs_top_down": paired_first_attempts(judged, judged, "network", "top_down")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noises", default=",".join(f"{n:g}" for n in NOISES))
    args = parser.parse_args()
    clean = json.loads((HERE / "results" / "picks.json").read_text())["sets"]
    kept = json.loads(RESULTS.read_text())["levels"] if RESULTS.is_file() else []
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_depth_noise", "date": date.today().isoformat(),
           "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "levels": kept}
    for noise in (float(n) for n in args.noises.split(",")):
        found = level(noise, clean)
        out["levels"] = sorted([lv for lv in out["levels"] if lv["noise"] != noise] + [found],
                               key=lambda lv: lv["noise"])
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({lv["noise"]: lv["versus_clean"] for lv in out["levels"]}, indent=1))


if __name__ == "__main__":
    main()
