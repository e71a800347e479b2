"""Branch experiment (image-veils): the camera drops flying pixels from its depth image (CameraSpec.drop_flying,
sim.views.flying_mask) before back-projecting; one set at a time, Franka hand, 24 views, the micrometre level.

    .venv/bin/python -m benchmarks.experiments.pick_image_veils SHARE SET

Results: data/pick_image_veils/SHARE/SET/picks.json (merged by hand into benchmarks/results/pick_image_veils.json).
"""

import sys

from benchmarks.experiments.pick_clutter import shipped_for
from benchmarks.experiments.pick_curve import ROOT
from benchmarks.experiments.pick_depth_noise import BASELINE, METHODS
from benchmarks.experiments.picks import ATTEMPTS, sets
from onepiece_dist.picks.runner import run_picks
from onepiece_dist.specs.plan import CameraSpec, PickSpec, PlanSpec

share, name = float(sys.argv[1]), sys.argv[2]
objects, _ = sets()[name]
shipped, hand = shipped_for("panda")
spec = PickSpec(objects=objects(), checkpoint=str(shipped), gripper=hand, views=24, attempts=ATTEMPTS, pictures=0,
                methods=METHODS, camera=CameraSpec(depth_noise=BASELINE, flying_pixels=share, drop_flying=True),
                plan=PlanSpec(denoise="auto"), output=str(ROOT / "data" / "pick_image_veils" / f"{share:g}" / name))
report = run_picks(spec)
print(share, name, {m["method"]: m["first_attempt"] for m in report.to_json()["methods"]}, flush=True)
