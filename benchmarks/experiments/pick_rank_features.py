"""Why the shipped network's best grasps fail, and whether what the view shows of them tells the surer apart (issue
55: the surest of its first three picks 4.9 and 8.9 points more often than its first). The views of
pick_ranked_draws are seen again; each of the network's 10 best-ranked grasps is executed at the same 8 draws
again, now keeping why each failed, and described by what the view shows of it (picks.rank_features: how steeply
it comes from above, where on the object's height it closes, how far off the object's axis, how many points fill
its closing region, how wide the observed object is between its fingers, the object's size). The draws must agree
with the stored ones (what the world executed before moves a rare outcome: counted). Then a prior: a logistic
model of the share of draws on those features and the network's score, fitted on the household set's grasps and
judged on the unseen set's (nothing was chosen on it), and object by object on the household set (each object
judged by a model fitted without it).

    .venv/bin/python -m benchmarks.experiments.pick_rank_features

Results: benchmarks/results/pick_rank_features.json, rendered into docs/picks.md.
"""

from __future__ import annotations

import json
import platform
import time
from datetime import date
from multiprocessing import get_context

import numpy as np

from benchmarks.experiments.pick_ceiling import _spec
from benchmarks.experiments.pick_curve import HERE, ROOT
from benchmarks.experiments.pick_ranked_draws import RESULTS as RANKED
from benchmarks.experiments.pick_ranked_draws import TOP, seen_again

RESULTS = HERE / "results" / "pick_rank_features.json"
ROWS = ROOT / "data" / "pick_rank_features"
NOISE_SAMPLES = 16  # the score under pose noise (pick_robust_rank's mean_x1) joins the prior's features


def _set(task) -> tuple[str, list[dict], list[str]]:
    """Each stored view of one set seen again: per ranked grasp its features and each draw's outcome."""
    import torch

    from onepiece_dist.picks.object_picks import process_scorer
    from onepiece_dist.picks.rank_features import rank_features
    from onepiece_dist.picks.views import Executions
    from onepiece_dist.plan.robust import perturbed_scores

    which, objects, stored, draws = task
    torch.set_num_threads(1)
    spec = _spec(which, objects)
    scorer = process_scorer(spec)
    rows, moved = [], []
    for again in seen_again(spec, scorer, objects, stored, TOP, moved):
        view, proposals, chosen = again.stored, again.seen.proposals, np.array(again.chosen)
        executions = Executions(spec, again.world, again.mesh, again.seen.resting, view["view"])
        outcomes = [executions.drawn("view", i, proposals.poses[i], draws) for i in chosen]
        noise = np.random.default_rng([again.number, view["view"], 55])
        under_noise = perturbed_scores(proposals, chosen, scorer, scorer.record, NOISE_SAMPLES,
                                       spec.sim.pose_noise, spec.sim.rotation_noise, noise).mean(axis=1)
        features = np.column_stack([rank_features(proposals, chosen, again.scores, scorer.gripper), under_noise])
        rows.append({"object": again.ref.name, "view": view["view"], "stored": view["draws"],
                     "picked": [[o.success for o in each] for each in outcomes],
                     "failures": [[o.failure for o in each] for each in outcomes],
                     "features": features.tolist()})
    return which, rows, moved


def failure_table(rows: list[dict]) -> dict:
    """How the draws of the first, second and third ranked grasp ended: counts by reason ('' = picked)."""
    table = {}
    for rank in range(3):
        ends = [f or "picked" for row in rows for f in row["failures"][rank]]
        table[str(rank + 1)] = {name: ends.count(name) for name in sorted(set(ends))}
    return table


def _fit(x: np.ndarray, y: np.ndarray, steps: int = 3000, rate: float = 0.1, decay: float = 1e-3) -> tuple:
    """A logistic model of shares ``y`` (n,) on features ``x`` (n, f), standardized: (mean, std, weights)."""
    mean, std = x.mean(axis=0), x.std(axis=0) + 1e-9
    z = np.concatenate([(x - mean) / std, np.ones((len(x), 1))], axis=1)
    w = np.zeros(z.shape[1])
    for _ in range(steps):
        p = 1 / (1 + np.exp(-z @ w))
        w -= rate * (z.T @ (p - y) / len(y) + decay * np.r_[w[:-1], 0])
    return mean, std, w


def _predict(model: tuple, x: np.ndarray) -> np.ndarray:
    mean, std, w = model
    return np.concatenate([(x - mean) / std, np.ones((len(x), 1))], axis=1) @ w


def _xy(rows: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([np.array(row["features"]) for row in rows])
    y = np.concatenate([np.mean(row["picked"], axis=1) for row in rows])
    return x, y


def chosen_share(rows: list[dict], model: tuple | None, k: int) -> float:
    """The mean share of draws of the grasp the model (None: the network's order) puts first of each view's first
    ``k``."""
    shares = []
    for row in rows:
        picked = np.mean(row["picked"], axis=1)
        best = 0 if model is None else int(np.argmax(_predict(model, np.array(row["features"])[:k])))
        shares.append(picked[best])
    return float(np.mean(shares))


def prior_trial(household: list[dict], unseen: list[dict]) -> dict:
    """The logistic prior fitted on the household grasps, judged on the unseen set's; and object by object."""
    model = _fit(*_xy(household))
    by_object = {}
    for name in sorted({row["object"] for row in household}):
        fitted = _fit(*_xy([row for row in household if row["object"] != name]))
        held = [row for row in household if row["object"] == name]
        by_object[name] = {str(k): (chosen_share(held, None, k), chosen_share(held, fitted, k)) for k in (3, 10)}
    left_out = {str(k): [float(np.mean([v[str(k)][i] for v in by_object.values()])) for i in (0, 1)]
                for k in (3, 10)}
    return {"weights": model[2].round(4).tolist(),
            "unseen": {str(k): [chosen_share(unseen, None, k), chosen_share(unseen, model, k)] for k in (3, 10)},
            "household_left_out": left_out, "household_by_object": by_object}


def by_object(rows: list[dict]) -> dict:
    """Per object: how the first ranked grasp's draws ended, and the mean share of draws of the first, of the
    surest of the first 3 and of the surest of the first 10 (the surest: the most draws picked)."""
    out = {}
    for name in sorted({row["object"] for row in rows}):
        mine = [row for row in rows if row["object"] == name]
        ends = [f or "picked" for row in mine for f in row["failures"][0]]
        shares = np.array([np.mean(row["picked"], axis=1) for row in mine])
        out[name] = {"first": {end: ends.count(end) for end in sorted(set(ends))},
                     "shares": [float(shares[:, 0].mean()), float(shares[:, :3].max(axis=1).mean()),
                                float(shares.max(axis=1).mean())]}
    return out


def summarize(found: list[tuple[str, list[dict], list[str]]], seconds: float) -> dict:
    """The results of each set's rows: the draws' agreement with the stored ones, failures, objects, the prior."""
    from onepiece_dist.picks.rank_features import FEATURES

    measured = {}
    for which, rows, moved in found:
        agree = [a == b for row in rows for s, p in zip(row["stored"], row["picked"], strict=True)
                 for a, b in zip(s, p, strict=True)]
        measured[which] = {"views": len(rows), "views_elsewhere": moved, "draws_agree": float(np.mean(agree)),
                           "failures": failure_table(rows), "objects": by_object(rows)}
    rows = {which: set_rows for which, set_rows, _ in found}
    return {"command": ".venv/bin/python -m benchmarks.experiments.pick_rank_features",
            "date": date.today().isoformat(), "machine": f"{platform.machine()}, {platform.processor() or 'cpu'}",
            "features": [*FEATURES, "score_under_noise"], "seconds": round(seconds, 1), "sets": measured,
            "prior": prior_trial(rows["household"], rows["unseen"])}


def main() -> None:
    from benchmarks.experiments.household import UNSEEN, household_objects

    ranked = json.loads(RANKED.read_text())
    sets = {"household": str(household_objects()), "unseen": str(household_objects(objects=UNSEEN))}
    start = time.perf_counter()
    with get_context("spawn").Pool(2) as pool:
        found = pool.map(_set, [(w, o, ranked["sets"][w]["rows"], ranked["draws"]) for w, o in sets.items()])
    ROWS.mkdir(parents=True, exist_ok=True)
    for which, set_rows, _ in found:
        (ROWS / f"{which}.json").write_text(json.dumps(set_rows))
    RESULTS.write_text(json.dumps(summarize(found, time.perf_counter() - start), indent=1) + "\n")
    print(RESULTS.read_text()[:3000])


if __name__ == "__main__":
    main()
