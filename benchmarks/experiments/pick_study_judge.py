"""The pick study's judgement (benchmarks/experiments/pick_study.py): every arm's networks pick the held-out sets'
views (picks.networks: one pass over the views for all networks), B against random labels of its size (a paired
interval over objects), and the ceiling measured from held-out candidates executed again and again
(picks.draws), each arm's AP placed against it. Picks and draws are kept under data/pick_study with what they were
asked, so a run again redoes only what changed."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "data" / "pick_study"
STUDY_SEED = 0
CONFIDENCE, BOOTSTRAP = 0.95, 2000
VIEWS = 8
CEILING_PER_VIEW, CEILING_DRAWS = 2, 16  # 256 household candidates, 16 executions each


def held_out_sets() -> dict[str, tuple[str, str, bool]]:
    """{name: (objects, what it is, whether designs were chosen on it)}; the first decides."""
    from benchmarks.experiments.household import UNSEEN, household_objects

    return {"household": (str(household_objects()), "robosuite's and LIBERO's meshes; the design and the shipped "
                          "network were chosen on these views", True),
            "unseen": (str(household_objects(objects=UNSEEN)), "more of LIBERO's meshes; nothing was ever chosen on "
                       "them", False)}


def pick_spec(objects: str, checkpoint: str, name: str):
    from onepiece_dist.specs.plan import PickSpec

    return PickSpec(objects=objects, checkpoint=checkpoint, output=str(OUT / "picks" / name), views=VIEWS,
                    attempts=1, seed=STUDY_SEED, methods=("network",), pictures=0,
                    plan={"top_down": False, "check_first": 0})  # the pool the study was judged on (before the
    # top-down trial), the network's order alone


def cached(name: str, asked: dict, make) -> list[dict]:
    """``make()``'s list of records, kept in OUT/<name>.json with ``asked``: made again only when asked anew."""
    path = OUT / f"{name}.json"
    if path.is_file():
        kept = json.loads(path.read_text())
        if kept["asked"] == asked:
            return kept["records"]
    records = [asdict(r) for r in make()]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"asked": asked, "records": records}) + "\n")
    return records


def set_picks(name: str, objects: str, checkpoints: list[str]) -> list[dict]:
    from onepiece_dist.picks.networks import run_network_picks

    spec = pick_spec(objects, str(ROOT / checkpoints[0]), name)
    asked = {"checkpoints": checkpoints, "spec": spec.model_dump(mode="json", exclude={"checkpoint"})}
    print(f"picks: {len(checkpoints)} networks on {name}", flush=True)
    return cached(f"picks_{name}", asked, lambda: run_network_picks(spec, tuple(str(ROOT / c) for c in
                                                                                 checkpoints)))


def ceiling_draws(objects: str, checkpoints: list[str]) -> list[dict]:
    from onepiece_dist.picks.draws import run_candidate_draws

    spec = pick_spec(objects, str(ROOT / checkpoints[0]), "ceiling")
    asked = {"checkpoints": checkpoints, "spec": spec.model_dump(mode="json", exclude={"checkpoint"}),
             "per_view": CEILING_PER_VIEW, "draws": CEILING_DRAWS}
    print(f"ceiling: {CEILING_PER_VIEW} candidates per view, {CEILING_DRAWS} draws each", flush=True)
    return cached("ceiling", asked, lambda: run_candidate_draws(spec, tuple(str(ROOT / c) for c in checkpoints),
                                                                CEILING_PER_VIEW, CEILING_DRAWS))


def judged(all_labels, arms, seeds: list[int], fits: dict) -> dict:
    """The study's record (study.pick_study.result.PickStudyResult as JSON) from the fitted arms."""
    from benchmarks.experiments.pick_unseen import DESIGN
    from onepiece_dist.stats.ranking import can_separate
    from onepiece_dist.study.picks import paired_verdict, rates_measure

    checkpoints = [fits[(arm.name, seed)]["checkpoint"] for arm in arms for seed in seeds]
    column = {(arm.name, seed): k for k, (arm, seed) in enumerate((a, s) for a in arms for s in seeds)}
    sets, picks, versus, held_out = [], {}, {}, held_out_sets()
    for name, (objects, what, chosen) in held_out.items():
        ok = [r for r in set_picks(name, objects, checkpoints) if r["status"] == "ok"]
        picked = np.array([r["picked"] for r in ok], dtype=float)  # objects x views x networks
        guess = np.array([r["random"] for r in ok], dtype=float).mean(axis=1)
        random = rates_measure(guess[:, None], STUDY_SEED, BOOTSTRAP, CONFIDENCE)
        sets.append({"name": name, "what": what, "chosen_on": chosen, "objects": len(ok), "views": int(picked.size
                     // max(picked.shape[2], 1)), "random": random.model_dump(), "separable": can_separate(
                     random.mean)})
        for arm in arms:
            rates = picked[:, :, [column[(arm.name, s)] for s in seeds]].mean(axis=1)  # objects x seeds
            picks.setdefault(arm.name, {})[name] = {
                "first_attempt": rates_measure(rates, STUDY_SEED, BOOTSTRAP, CONFIDENCE).model_dump(),
                "per_object": [round(float(x), 4) for x in rates.mean(axis=1)],
                "per_seed": [round(float(x), 4) for x in rates.mean(axis=0)]}
        versus[name] = {arm.name: paired_verdict(np.array(picks[arm.name][name]["per_object"]),
                                                 np.array(picks[f"R ~{arm.name}"][name]["per_object"]),
                                                 STUDY_SEED, BOOTSTRAP, CONFIDENCE)
                        for arm in arms if arm.kind == "B"}
    ceiling, aps = measured(held_out["household"][0], checkpoints, arms, seeds, column)
    per_label = all_labels.attrs["core_seconds"] / len(all_labels)
    return {"design": {"name": DESIGN, **fits[(arms[0].name, seeds[0])]["options"], "seed": None},
            "labels": {"rows": len(all_labels), "objects": len(np.unique(all_labels.object)),
                       "success_rate": round(float(all_labels.success.mean()), 4),
                       "core_seconds": all_labels.attrs["core_seconds"],
                       "sources": [s["objects"] for s in all_labels.attrs["specs"]]},
            "sets": sets, "b_versus_random": versus, "ceiling": ceiling, "confidence": CONFIDENCE,
            "arms": [{"name": arm.name, "kind": arm.kind, "radius": arm.radius, "labels": arm.labels,
                      "label_core_seconds": round(arm.labels * per_label + arm.seconds, 1),
                      "fit_seconds": [fits[(arm.name, s)]["fit_seconds"] for s in seeds],
                      "checkpoints": [fits[(arm.name, s)]["checkpoint"] for s in seeds],
                      "picks": picks[arm.name], **aps[arm.name]} for arm in arms]}


def measured(objects: str, checkpoints: list[str], arms, seeds: list[int], column: dict) -> tuple[dict, dict]:
    """The measured ceiling on ``objects`` and each arm's AP against the same draws (single networks, ensemble)."""
    from onepiece_dist.stats.ceiling import ap_against_draws, label_ceiling, measured_ceiling

    ok = [r for r in ceiling_draws(objects, checkpoints) if r["status"] == "ok"]
    draws = np.array([d for r in ok for d in r["draws"]], dtype=bool)
    scores = np.array([s for r in ok for s in r["scores"]], dtype=float)
    found = measured_ceiling(draws, seed=STUDY_SEED)
    ceiling = {"set": "household", "grasps": found.grasps, "draws": found.draws,
               "positive_rate": round(found.positive_rate, 4), "agreement": round(label_ceiling(draws).agreement, 4),
               "ap": round(found.ap, 4), "low": round(found.low, 4), "high": round(found.high, 4),
               "moment_range": [round(x, 4) for x in found.moment_range]}
    aps = {}
    for arm in arms:
        mine = scores[:, [column[(arm.name, s)] for s in seeds]]
        aps[arm.name] = {"ap_single": round(float(np.mean([ap_against_draws(mine[:, k], draws)
                                                           for k in range(mine.shape[1])])), 4),
                         "ap_ensemble": round(ap_against_draws(mine.mean(axis=1), draws), 4)}
    return ceiling, aps

