"""A study judged by picks (spec.judge: picks or both): every arm's networks (one per training seed) pick the
held-out objects from one depth view each (picks.networks), and the decision is made on pick success:
the cheapest arm whose mean lies inside A's interval, and each one-object arm against random labels of its size.

The picks are kept in ``picks/networks.json`` beside the study with what they were asked, so a study run again
picks only when its networks or settings changed.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from onepiece_dist.learn.train import StepResult
from onepiece_dist.picks.networks import run_network_picks
from onepiece_dist.specs.plan import PICK_SIM, PickSpec
from onepiece_dist.stats.intervals import bootstrap_interval
from onepiece_dist.stats.ranking import can_separate
from onepiece_dist.study.result import Arm, ArmPicks, Measure, PicksJudgement
from onepiece_dist.study.spec import StudySpec
from onepiece_dist.study.training import ArmRun, weights_at

PICKS_FILE = "networks.json"


def weights_base(folder: Path, arm: str, seed: int) -> str:
    """Where an arm's run at ``seed`` keeps its weights (the learning rate is added: training.weights_at)."""
    return str(folder / "runs" / "weights" / f"{re.sub(r'[^A-Za-z0-9.]+', '_', arm)}-s{seed}.pt")


def judges_picks(spec: StudySpec) -> bool:
    return spec.judge in ("picks", "both")


def pick_spec(spec: StudySpec, folder: Path, checkpoint: str):
    sim = PICK_SIM.model_copy(update={"label_trials": spec.label_trials, "success": spec.success,
                                      "load": spec.load, "load_mass": spec.load_mass})
    return PickSpec(objects=spec.picks.objects or spec.heldout, checkpoint=checkpoint, output=str(folder / "picks"),
                    views=spec.picks.views, attempts=1, seed=spec.seed, methods=("network",), pictures=0, sim=sim)


def judge_by_picks(spec: StudySpec, folder: Path, trained: list[tuple[ArmRun, StepResult]], arms: list[Arm],
                   say=lambda line: None) -> PicksJudgement:
    """The arms' pick success and the decision made on it (``arms``: the study's arms with their costs)."""
    checkpoints = tuple(weights_at(job.run.save_to, job.learning_rate) for job, _ in trained)
    picks = _picks(spec, folder, checkpoints, say)
    ok = [p for p in picks if p["status"] == "ok"]
    picked = np.array([p["picked"] for p in ok], dtype=float)  # objects x views x networks
    guess = np.array([p["random"] for p in ok], dtype=float).mean(axis=1)
    per_arm, per_object = {}, {}
    for arm in dict.fromkeys(job.arm for job, _ in trained):
        mine = [k for k, (job, _) in enumerate(trained) if job.arm == arm]
        per_object[arm] = picked[:, :, mine].mean(axis=1).mean(axis=1)
        per_arm[arm] = _measure(picked[:, :, mine].mean(axis=1), spec)  # objects x seeds
    a = per_arm["A"]
    random = Measure(mean=round(float(guess.mean()), 4), std=0.0,
                     interval=bootstrap_interval(guess, spec.seed, spec.targets.bootstrap_draws,
                                                 spec.targets.confidence))
    inside = {name: m.mean >= a.interval[0] for name, m in per_arm.items()}
    cost = {arm.name: arm.cost.core_seconds for arm in arms}
    cheapest = min((name for name in per_arm if inside[name]), key=lambda name: cost.get(name, float("inf")))
    separable = can_separate(random.mean)
    versus = {n: compare(per_object[n], per_object[f"R ~{n}"], spec) for n in per_arm
              if n.startswith("B ") and f"R ~{n}" in per_arm}
    return PicksJudgement(objects=len(ok), views=spec.picks.views,
                          label=f"{spec.label_trials} trials, {spec.success}", random=random, separable=separable,
                          arms=[ArmPicks(name=n, first_attempt=m, within_a=inside[n]) for n, m in per_arm.items()],
                          cheapest=cheapest,
                          b_beats_random={n: v == "beats" for n, v in versus.items()}, b_versus_random=versus)


def compare(arm: np.ndarray, other: np.ndarray, spec: StudySpec) -> str:
    return paired_verdict(arm, other, spec.seed, spec.targets.bootstrap_draws, spec.targets.confidence)


def paired_verdict(arm: np.ndarray, other: np.ndarray, seed: int, draws: int, confidence: float) -> str:
    """``arm`` against ``other`` (per-object rates of the same objects): 'beats' when the interval of their paired
    difference lies above zero, 'loses' when below, else 'ties' (equal means are a tie, never a win)."""
    low, high = bootstrap_interval(arm - other, seed, draws, confidence)
    return "beats" if low > 0 else "loses" if high < 0 else "ties"


def _measure(rates: np.ndarray, spec: StudySpec) -> Measure:
    return rates_measure(rates, spec.seed, spec.targets.bootstrap_draws, spec.targets.confidence)


def rates_measure(rates: np.ndarray, seed: int, draws: int, confidence: float) -> Measure:
    """``rates`` (objects, seeds): the mean, the spread over seeds, the interval over objects."""
    per_object = rates.mean(axis=1)
    interval = bootstrap_interval(per_object, seed, draws, confidence)
    return Measure(mean=round(float(per_object.mean()), 4), std=round(float(rates.mean(axis=0).std()), 4),
                   interval=(round(interval[0], 4), round(interval[1], 4)))


def _picks(spec: StudySpec, folder: Path, checkpoints: tuple[str, ...], say) -> list[dict]:
    path = folder / "picks" / PICKS_FILE
    asked = {"checkpoints": [str(Path(c).relative_to(folder)) for c in checkpoints],
             "pick": pick_spec(spec, folder, checkpoints[0]).model_dump(mode="json", exclude={"checkpoint",
                                                                                             "output"})}
    if path.is_file():
        kept = json.loads(path.read_text())
        if kept["asked"] == asked:
            return kept["objects"]
    say(f"study: picks: {len(checkpoints)} networks on the held-out objects, {spec.picks.views} views each")
    found = [asdict(p) for p in run_network_picks(pick_spec(spec, folder, checkpoints[0]), checkpoints)]
    path.write_text(json.dumps({"asked": asked, "objects": found}) + "\n")
    return found
