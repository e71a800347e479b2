"""The default job's network carried to other hands (results/pick_carried.json,
benchmarks/experiments/pick_carried.py): for each preset hand, the carried network beside the hand's own shipped
network and the top-down baseline on the same views."""

from __future__ import annotations

from benchmarks.pages.pick_own_section import both_sets, cell, heuristic_picks, pooled_cell, pooled_rate
from benchmarks.pages.pick_trials_section import VIEWS
from onepiece_dist.stats.intervals import paired_gain

SETS = ("household", "unseen")


def _name(hand: dict) -> str:
    return hand["gripper"] + (" read from its URDF" if hand["hand"].endswith("_urdf") else "")


def _region(hand: dict) -> str:
    r = hand["region"]
    size = " x ".join(f"{100 * r[n]:g}" for n in ("closing_depth", "closing_width", "closing_height"))
    return f"{size} cm ({'the same' if hand['same_region'] else 'larger'})"


def _against(tried: dict, base: dict, set_names: tuple[str, ...]) -> str:
    """The paired gain of ``tried`` over ``base`` on the objects of ``set_names``: points [interval over objects]."""
    pick = both_sets if len(set_names) == 2 else (lambda p: p[set_names[0]]["per_object"])
    gain = paired_gain([pick(tried)], [pick(base)], VIEWS)
    low, high = gain.interval
    return f"{100 * gain.gain:+.1f} points [{100 * low:+.1f}, {100 * high:+.1f}]"


def carried_section(result: dict) -> list[str]:
    lines = [f"## The default job's network carried to other hands: `{result['command']}`", "",
             f"{result['date']}, {result['machine']}. Where no network ships for a hand whose closing region (the "
             "box every crop is cut in) holds the default job's gripper's, the planner asked to (`--carry`, "
             "`PlanSpec.carry`) carries the default job's network to it (`plan.shipped.planning_network`): its "
             "grasps proposed, checked and executed by that hand, its crops cut in the network's own region (the "
             "shapes it was trained on). Here it is carried to each preset hand, beside that hand's own shipped "
             "network, and to the Franka Panda read from pybullet_data's URDF (none ships for it: beside it the "
             "network its refusal's fix makes, pick-labels and pick-train with their defaults), with the "
             f"top-down baseline on the same views ({result['views']} views an object, the planner's defaults: its "
             "first 3 grasps checked), first attempt:", "",
             "| hand | closing region (against the box gripper's) | network | household | unseen | both sets "
             "(28 objects) |", "| --- | --- | --- | --- | --- | --- |"]
    for hand in result["hands"]:
        carried, own = hand["carried_picks"], hand["own_picks"]
        made = hand.get("made")
        rows = (("carried", carried), *((("its own", own),) if own else ()),
                *(((f"made by pick-labels and pick-train ({made['labels']} labels)", made["picks"]),) if made else ()),
                ("top-down", heuristic_picks(carried)))
        lines += [f"| {_name(hand)} | {_region(hand)} | {name} | {cell(p['household'])} | {cell(p['unseen'])} | "
                  f"{pooled_cell(p)} |" for name, p in rows]
    lines.append("")
    for hand in result["hands"]:
        carried, own = hand["carried_picks"], hand["own_picks"]
        mine = own or (hand.get("made") or {}).get("picks")
        against_own = (f"against its {'own' if own else 'made'} network {_against(carried, mine, SETS)} over both "
                       f"sets, {_against(carried, mine, ('household',))} on the household set; " if mine else
                       "no network ships for it; ")
        made, top_down = (hand.get("made") or {}).get("picks"), heuristic_picks(carried)
        made_line = (f" The made network against top-down: {_against(made, top_down, SETS)} over both sets."
                     if made else "")
        lines += [f"- {_name(hand)}, carried, paired over objects: {against_own}against top-down "
                  f"{_against(carried, top_down, SETS)} over both sets.{made_line}"]
    below = [_name(h) for h in result["hands"]
             if pooled_rate(h["carried_picks"])[0] < pooled_rate(heuristic_picks(h["carried_picks"]))[0]]
    lines += ["", f"Carried to {', '.join(below) or 'none of them'} the network picks less than top-down over both "
              "sets: carrying is asked for (`--carry`), not assumed. A hand whose closing region is smaller than "
              "the network's in any extent is refused even so, naming the "
              "fields: the network would judge points its fingers cannot reach. A preset's own network is replaced "
              "only where the carried one's interval over the household objects lies above zero (the trials' "
              "rule).", ""]
    return lines
