"""Branch experiment (image-veils): pick_image_veils' set reports merged and paired over objects against the camera
keeping every pixel (pick_flying_pixels' 24-view Franka runs: its committed flying run, its exact level's reports
under data/).

    .venv/bin/python -m benchmarks.experiments.pick_image_veils_merge

Results: benchmarks/results/pick_image_veils.json.
"""

import json
import subprocess
from datetime import date

from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_depth_noise import METHODS, SETS
from benchmarks.experiments.pick_flying_pixels import RESULTS as FLYING
from benchmarks.experiments.pick_flying_pixels import views_of
from benchmarks.experiments.pick_panda_check import slim
from benchmarks.pages.pick_sets import paired_first_attempts, pooled


def reports(folder) -> list[dict]:
    return [{**json.loads((folder / name / "picks.json").read_text()), "name": name} for name in SETS]


def main() -> None:
    flying = next(r["sets"] for r in json.loads(FLYING.read_text())["runs"]
                  if (r["gripper"], r["flying"], views_of(r)) == ("panda", 1.0, 24))
    kept = {1.0: flying, 0.0: reports(ROOT / "data" / "pick_flying_pixels" / "panda" / "exact_24" / "1e-06_auto")}
    runs = []
    for share in (1.0, 0.0):
        made = reports(ROOT / "data" / "pick_image_veils" / f"{share:g}")
        runs.append({"flying": share, "sets": [slim(s) for s in made],
                     "pooled": {m: pooled(made, m) for m in METHODS},
                     "versus_kept": {m: paired_first_attempts(made, kept[share], m) for m in METHODS}})
        print(share, {m: (round(100 * v["mean"], 1), [round(100 * x, 1) for x in v["interval"]])
                      for m, v in runs[-1]["versus_kept"].items()})
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT,
                            check=False).stdout.strip()
    out = {"command": ".venv/bin/python -m benchmarks.experiments.pick_image_veils", "date": date.today().isoformat(),
           "commit": commit, "gripper": "panda", "views": 24, "runs": runs}
    (HERE / "results" / "pick_image_veils.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
