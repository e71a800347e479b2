"""The test suite's section of docs/performance.md, from benchmarks/results/suite.json
(benchmarks/speed/bench_suite.py)."""

from __future__ import annotations

from benchmarks.pages.committed import met
from onepiece_dist.study.markdown import provenance, table

GROUP_WORDS = {"ray": "the tests that start Ray", "rest": "the rest"}
COSTLIEST = 15


def suite_section(r: dict) -> list[str]:
    suite, target = r["suite"], r["target_seconds"]
    counts = ", ".join(f"{count} {name}" for name, count in suite["outcomes"].items())
    return [f"## The test suite: {provenance(r)}", "",
            f"The README's test command (`scripts/dev test`: one pytest worker per core, the tests that start Ray one "
            f"at a time on one of them, the rest beside them at a lower CPU priority: tests/conftest.py): {counts} in "
            f"{suite['wall_seconds']:.0f} s, {_busy(suite)} on {r['cores']} cores. Target: within about 10 minutes "
            f"({target} s): **{met(-suite['wall_seconds'], -target)}**.{_cache_words(r)}", "",
            "Each group alone in one process (`-n 0`), with the machine's busy CPU-seconds meanwhile (every "
            "process's: Ray's daemons and actors and the children a test starts count):", "",
            *table(["group", "tests", "wall (s)", "busy CPU-seconds", "cores busy on average"],
                   [[f"{GROUP_WORDS.get(g['name'], g['name'])} (`-m \"{g['marker']}\"`)", len(g["tests"]),
                     f"{g['wall_seconds']:.0f}", _number(g["busy_seconds"]), _cores(g)] for g in r["groups"]]),
            "", *_floor_lines(r), "", f"The {COSTLIEST} costliest tests, each alone:", "",
            *table(["test", "group", "wall (s)", "busy CPU-seconds"], _costliest(r))]


def _cache_words(r: dict) -> str:
    """What the runs found in the user's cache (the local jobs' shared decompositions: sim.collision)."""
    if r.get("user_cache") is None:
        return ""
    return (f" The user's cache was {r['user_cache']} (a fresh `XDG_CACHE_HOME`): every decomposition the local "
            "jobs share was made during the run, as on a fresh machine.")


def _floor_lines(r: dict) -> list[str]:
    floor, target = r["floor_seconds"], r["target_seconds"]
    if floor is None:
        return ["No floor: this machine does not say its busy CPU-seconds (/proc/stat)."]
    busy = sum(g["busy_seconds"] for g in r["groups"])
    verdict = (f"no order or number of workers reaches the target on these cores: the tests' CPU must shrink by "
               f"{busy - target * r['cores']:.0f} CPU-seconds ({1 - target * r['cores'] / busy:.0%})"
               if floor > target else "the target is within reach of scheduling alone")
    return [f"The floor, both groups' {busy:.0f} busy CPU-seconds over {r['cores']} cores: {floor:.0f} s against "
            f"the target's {target} s (**{met(-floor, -target)}**): {verdict}. The suite as the README runs it took "
            f"{r['suite']['wall_seconds'] / floor:.2f} times the floor."]


def _costliest(r: dict) -> list[list]:
    rows = [(t, g["name"]) for g in r["groups"] for t in g["tests"]]
    rows.sort(key=lambda row: -(row[0]["busy"] or 0))
    return [[f"`{t['test']}`", GROUP_WORDS.get(name, name), f"{t['wall']:.1f}", _number(t["busy"])]
            for t, name in rows[:COSTLIEST]]


def _busy(measured: dict) -> str:
    busy = measured["busy_seconds"]
    return "busy CPU-seconds not known" if busy is None else f"{busy:.0f} busy CPU-seconds"


def _cores(g: dict) -> str:
    return "-" if g["busy_seconds"] is None else f"{g['busy_seconds'] / g['wall_seconds']:.2f}"


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f}"
