"""The study's decision: which arms are as good as labelling everything (A) on the held-out objects, the cheapest
of them, whether it meets the targets, and whether the one object beats a random subset of its size. Every
threshold comes from the spec's :class:`~onepiece_dist.study.spec.StudyTargets`."""

from __future__ import annotations

from dataclasses import dataclass

from onepiece_dist.study.result import Arm, ArmCost, Decision, HeldoutScore
from onepiece_dist.study.spec import StudyTargets


@dataclass(frozen=True)
class ArmDraft:
    """An arm before it is compared with A."""

    name: str
    kind: str
    cost: ArmCost
    heldout: HeldoutScore
    radius: int | None = None
    share: float | None = None
    unique_codes: int | None = None


def as_good_as(row: HeldoutScore, reference: HeldoutScore) -> bool:
    """Mean top-1 and mean AP both inside the reference's intervals, or above them (rounded to 4 places as the
    page shows them)."""
    return (round(row.top1.mean, 4) >= reference.top1.interval[0]
            and round(row.ap.mean, 4) >= reference.ap.interval[0])


def finish_arms(drafts: list[ArmDraft]) -> list[Arm]:
    """Each arm with its ratios to A (the first draft) and whether it is as good as A."""
    a = drafts[0]
    if a.kind != "A":
        raise ValueError(f"the first arm must be A, got {a.name!r}")
    return [Arm(name=d.name, kind=d.kind, radius=d.radius, share=d.share, unique_codes=d.unique_codes, cost=d.cost,
                heldout=d.heldout,
                time_ratio=round(a.cost.core_seconds / max(d.cost.core_seconds, 1e-9), 3),
                storage_ratio=round(a.cost.labelled_bytes / max(d.cost.labelled_bytes, 1), 3),
                within_a=as_good_as(d.heldout, a.heldout))
            for d in drafts]


def matched_random(arm: Arm, arms: list[Arm]) -> Arm | None:
    """The R arm of a B arm's size (``R ~<B arm's name>``)."""
    return next((r for r in arms if r.kind == "R" and r.name == f"R ~{arm.name}"), None)


def b_beats_r(b: Arm, r: Arm) -> bool:
    """B's mean top-1 and mean AP both at least R's."""
    return all(round(getattr(b.heldout, m).mean, 4) >= round(getattr(r.heldout, m).mean, 4) for m in ("top1", "ap"))


def decide(arms: list[Arm], targets: StudyTargets) -> Decision:
    good = [arm for arm in arms if arm.within_a]
    cheapest = min(good, key=lambda arm: arm.cost.core_seconds) if good else None
    good_b = [arm for arm in good if arm.kind == "B"]
    best_b = min(good_b, key=lambda arm: arm.cost.core_seconds) if good_b else None
    versus = {}
    for b in (arm for arm in arms if arm.kind == "B"):
        control = matched_random(b, arms)
        if control is not None:
            versus[b.name] = b_beats_r(b, control)
    named = {arm.name: arm for arm in arms}
    u_beats = b_beats_r(named["U"], named["R ~U"]) if {"U", "R ~U"} <= set(named) else None
    return Decision(
        **adaptive_target(named.get("U"), arms, targets),
        cheapest=cheapest.name if cheapest else None,
        cheapest_core_seconds=cheapest.cost.core_seconds if cheapest else None,
        cheapest_label_trials=cheapest.cost.label_trials if cheapest else None,
        cheapest_labelled_bytes=cheapest.cost.labelled_bytes if cheapest else None,
        cheapest_time_ratio=cheapest.time_ratio if cheapest else None,
        cheapest_storage_ratio=cheapest.storage_ratio if cheapest else None,
        time_met=bool(cheapest and cheapest.time_ratio >= targets.time_ratio),
        storage_met=bool(cheapest and cheapest.storage_ratio >= targets.storage_ratio),
        best_b=best_b.name if best_b else None, b_beats_random=versus, u_beats_random=u_beats)


def adaptive_target(u: Arm | None, arms: list[Arm], targets: StudyTargets) -> dict:
    """Issue 39's targets for the adaptive arm U: inside A's intervals at no more than targets.adaptive_share of
    A's core-seconds, and fewer labels than random labels need for the same held-out AP."""
    if u is None:
        return {}
    share = u.cost.core_seconds / max(arms[0].cost.core_seconds, 1e-9)
    reaching = [r.cost.labelled_grasps for r in arms
                if r.kind == "R" and round(r.heldout.ap.mean, 4) >= round(u.heldout.ap.mean, 4)]
    return {"u_cost_share": round(share, 4), "u_met": bool(u.within_a and share <= targets.adaptive_share),
            "r_labels_at_u_ap": min(reaching) if reaching else None}
