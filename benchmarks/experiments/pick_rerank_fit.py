"""A second look at the network's best grasps (issue 55: the surest of the network's first three picks 4.9 and 8.9
points more than its first, and no network fitted on labels drawn once tells them apart). The shipped network
fitted further on the drawn-again rows alone (picks.top_draws: its own 8 best grasps of 4 views of each of the
first batch's objects, each executed 4 times), the share of each row's draws as the target and a listwise term
pushing each view's surer grasps above the others, at a tenth of the rate, the best epoch by the AP on held-out
objects. Judged by benchmarks/experiments/pick_reranked (these networks choosing among the shipped network's first
grasps of the benchmark's views, judged by those grasps' draws); nothing is chosen on those views.

    .venv/bin/python -m benchmarks.experiments.pick_rerank_fit [--seeds 0,1]

Networks: data/pick_curve/rerank/rerank_s<seed>/best.pt; results: benchmarks/results/pick_rerank_fit.json.
"""

from __future__ import annotations

import argparse
import json
import platform
from dataclasses import asdict
from datetime import date

from benchmarks.experiments.pick_curve import HERE, OUT, ROOT

RESULTS = HERE / "results" / "pick_rerank_fit.json"
OPTIONS = {"model": "pointnet_context", "target": "draws", "ranking": 1.0, "learning_rate": 1e-4, "epochs": 12,
           "patience": 4}


def fit(seed: int) -> dict:
    import torch

    from benchmarks.experiments.pick_top_draws import FOLDER
    from onepiece_dist.learn.pick_train import PickTrainOptions, train_on_pick_labels
    from onepiece_dist.plan.shipped import shipped_network
    from onepiece_dist.store.pick_labels import read_pick_labels

    rows = read_pick_labels(ROOT / FOLDER / "pick_labels.zarr")
    network = shipped_network()
    crop = torch.load(network, map_location="cpu", weights_only=True)["crop"]
    options = PickTrainOptions(**OPTIONS, seed=seed, start_from=str(network))
    result = train_on_pick_labels(rows, OUT / "rerank" / f"rerank_s{seed}", crop, options)
    return {"seed": seed, "checkpoint": str(result.checkpoint.relative_to(ROOT)), "rows": len(rows),
            "fit_seconds": round(result.seconds, 1), "best_epoch": asdict(result.best),
            "epochs": [asdict(e) for e in result.epochs]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0,1")
    args = parser.parse_args()
    points = [fit(int(s)) for s in args.seeds.split(",")]
    RESULTS.write_text(json.dumps({
        "command": ".venv/bin/python -m benchmarks.experiments.pick_rerank_fit", "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}", "options": OPTIONS, "points": points},
        indent=1) + "\n")
    print(json.dumps([{k: p[k] for k in ("seed", "best_epoch")} for p in points], indent=1))


if __name__ == "__main__":
    main()
