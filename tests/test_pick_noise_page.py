"""The depth-noise section of docs/picks.md (benchmarks/pages/pick_noise_section.py): each level's chooser rates
beside the run without noise, and a change said only where its interval over objects excludes zero."""

from __future__ import annotations


def _set(name: str, network: list[bool], top_down: list[bool]) -> dict:
    """A pick benchmark set of one view per object: each object's first attempt per chooser."""
    objects = [{"name": f"o{k}", "status": "ok", "views": [{"attempts": {"network": (n,), "top_down": (t,)}}]}
               for k, (n, t) in enumerate(zip(network, top_down, strict=True))]
    rate = {m: sum(v) / len(v) for m, v in (("network", network), ("top_down", top_down))}
    return {"name": name, "objects": objects,
            "methods": [{"method": m, "first_attempt": r, "first_attempt_interval": [r, r]} for m, r in rate.items()]}


def test_the_noise_section_pairs_each_level_against_no_noise_and_says_a_change_only_where_it_is_shown():
    from benchmarks.experiments.pick_depth_noise import BASELINE, against_baseline, paired_first_attempts
    from benchmarks.pages.pick_noise_section import noise_section

    clean = [_set("household", [True] * 8, [False] * 8)]
    same, worse = _set("household", [True] * 8, [False] * 8), _set("household", [False] * 8, [False] * 8)

    def level(noise: float, judged: dict, denoise: str = "none") -> dict:
        return {"noise": noise, "denoise": denoise, "sets": [judged],
                "network_vs_top_down": paired_first_attempts([judged], [judged], "network", "top_down")}

    levels = against_baseline([level(BASELINE, clean[0]), level(0.001, same), level(0.004, worse),
                               level(BASELINE, clean[0], "auto"), level(0.004, same, "auto")])
    assert "versus_baseline" not in levels[0] and "versus_none" not in levels[2]
    lines = noise_section({"command": "c", "date": "d", "machine": "m", "levels": levels}, {"sets": clean})
    assert next(line for line in lines if line.startswith("0.001 mm, denoise none:")).endswith(
        "+100.0 points [+100.0, +100.0].")
    assert "| 1 mm | none | household | 100% [100%, 100%] | 0% [0%, 0%] | 100% [100%, 100%] |" in lines
    assert "| 4 mm | none | household | 0% [0%, 0%] | 0% [0%, 0%] | 100% [100%, 100%] |" in lines
    one = next(line for line in lines if line.startswith("1 mm, denoise none:"))
    four = next(line for line in lines if line.startswith("4 mm, denoise none:"))
    assert "+0.0 points [+0.0, +0.0] (not shown to differ)" in one and "the network over top-down +100.0" in one
    assert "-100.0 points [-100.0, -100.0] (lower)" in four and "paired over the 8 meshes" in four
    mended = next(line for line in lines if line.startswith("4 mm, denoise auto:"))
    assert "against `denoise: none` +100.0 points [+100.0, +100.0] (higher)" in mended
    assert "`denoise: auto` is **kept** as the planner's default" in lines[-1]
    hurt = against_baseline([level(0.004, same), level(0.004, worse, "auto")])
    assert "**not kept**" in noise_section({"command": "c", "date": "d", "machine": "m", "levels": hurt}, None)[-1]


def test_planner_variants_on_more_views_are_paired_against_the_variant_they_change_at_each_noise():
    from benchmarks.pages.pick_noise_section import noise_views_section

    def run(variant: str, noise: float, network: list[bool], against: str = "") -> dict:
        return {"variant": variant, "commit": "abc1234", "noise": noise,
                "sets": [_set("household", network, [False] * 8)], **({"against": against} if against else {})}

    half, all_ = [True] * 4 + [False] * 4, [True] * 8
    result = {"command": "c", "date": "d", "machine": "m", "views": 24,
              "runs": [run("before", 0.004, half), run("before", 0.002, half), run("after", 0.002, all_),
                       run("after", 0.004, half), run("worse", 0.002, all_), run("worse", 0.004, [False] * 8),
                       run("on after", 0.002, half, "after"), run("on after", 0.004, all_, "after")],
              "variants": {"before": "as it was", "after": "changed"}}
    lines = noise_views_section(result)
    assert lines[0] == "## The planner under noise on 24 views an object, the Franka hand: `c`"
    assert "| before | abc1234 | 2 mm | household | 50% [50%, 50%] | 0% [0%, 0%] |" in lines
    two = next(line for line in lines if line.startswith("- 2 mm, after against before"))
    four = next(line for line in lines if line.startswith("- 4 mm, after against before"))
    assert "network +50.0 points [" in two and "(higher), pooled 100% against 50%" in two
    assert "network +0.0 points [+0.0, +0.0] (not shown to differ)" in four
    assert not any(line.startswith("- 2 mm, before") for line in lines)
    assert "variant at the commit it ran at (before: as it was; after: changed), first attempt:" in lines[2]
    assert lines[-3].startswith("After against before: **kept**")
    assert lines[-2].startswith("Worse against before: **not kept**")
    on_after = next(line for line in lines if line.startswith("- 2 mm, on after against after"))
    assert "network -50.0 points" in on_after and "(lower)" in on_after  # against what it changes, not the first
    assert lines[-1].startswith("On after against after: **not kept**")


def test_the_flying_pixels_section_says_which_chooser_they_are_shown_to_cost():
    from benchmarks.experiments.pick_depth_noise import paired_first_attempts
    from benchmarks.pages.pick_flying_section import flying_section

    exact = _set("household", [True] * 8, [True] * 8)

    def run(judged: dict, **views) -> dict:
        return {"gripper": None, "flying": 1.0, **views, "sets": [judged],
                "network_vs_top_down": paired_first_attempts([judged], [judged], "network", "top_down"),
                "versus_exact": {m: paired_first_attempts([judged], [exact], m) for m in ("network", "top_down")},
                "exact": {"household": {"network": 1.0, "top_down": 1.0}}}

    held = flying_section({"command": "c", "date": "d", "machine": "m",
                           "runs": [run(_set("household", [True] * 8, [False] * 8))]})
    assert "| the default job's gripper | 1 | 8 | household | 100% [100%, 100%] | 0% [0%, 0%] | 100% | 100% |" in held
    assert held[-1].startswith("Flying pixels: top-down is shown to lose picks to them, the network is not")
    lost = flying_section({"command": "c", "date": "d", "machine": "m",
                           "runs": [run(_set("household", [False] * 8, [False] * 8))]})
    assert lost[-1] == "Flying pixels: both the network and top-down are shown to lose picks to them."
    at_more_views = flying_section({"command": "c", "date": "d", "machine": "m", "runs": [
        run(_set("household", [False] * 8, [False] * 8)), run(_set("household", [True] * 8, [False] * 8), views=24)]})
    assert "| the default job's gripper | 1 | 24 | household | 100% [100%, 100%] | 0% [0%, 0%] | 100% | 100% |" \
        in at_more_views  # both runs shown, the verdict read from the one at the most views
    assert at_more_views[-1].startswith("Flying pixels: top-down is shown to lose picks to them, the network is not")
    assert "at 24 views an object" in at_more_views[-1]


def test_dropping_the_veils_is_kept_only_where_it_picks_more_under_flying_pixels_and_no_less_on_exact_depth():
    from benchmarks.experiments.pick_depth_noise import paired_first_attempts
    from benchmarks.pages.pick_flying_section import veils_section

    every_point = _set("household", [False] * 4 + [True] * 4, [False] * 8)

    def run(share: float, judged: dict) -> dict:
        return {"flying": share, "sets": [judged],
                "network_vs_top_down": paired_first_attempts([judged], [judged], "network", "top_down"),
                "versus_kept": {m: paired_first_attempts([judged], [every_point], m) for m in ("network", "top_down")},
                "kept": {"household": {"network": 0.5, "top_down": 0.0}}}

    def verdict(*runs: dict) -> str:
        return veils_section({"command": "c", "date": "d", "machine": "m", "commit": "abc", "views": 24,
                              "runs": list(runs)})[-1]

    more, same, less = (_set("household", n, [False] * 8) for n in ([True] * 8, [False] * 4 + [True] * 4, [False] * 8))
    assert verdict(run(1.0, more), run(0.0, same)).startswith("Dropping the veils: **kept**")
    assert verdict(run(1.0, more), run(0.0, less)).startswith("Dropping the veils: **not kept**")
    assert verdict(run(1.0, same), run(0.0, same)).startswith("Dropping the veils: **not kept**")
    assert verdict(run(1.0, more)).startswith("Dropping the veils: judged under flying pixels and on exact depth")
    lines = veils_section({"command": "c", "date": "d", "machine": "m", "commit": "abc", "views": 24,
                           "runs": [run(1.0, more)]})
    assert "| 1 | household | 100% [100%, 100%] | 0% [0%, 0%] | 50% | 0% |" in lines


def test_dropping_flying_pixels_is_kept_at_a_tolerance_whose_most_viewed_runs_pick_more_flying_and_no_less_exact():
    from benchmarks.experiments.pick_depth_noise import paired_first_attempts
    from benchmarks.pages.pick_flying_section import drop_section
    from benchmarks.pages.pick_sets import pooled

    every_pixel = _set("household", [False] * 4 + [True] * 4, [False] * 8)

    def run(tolerance: float, share: float, views: int, judged: dict) -> dict:
        return {"tolerance": tolerance, "flying": share, "views": views, "sets": [judged],
                "pooled": {m: pooled([judged], m) for m in ("network", "top_down")},
                "kept_pooled": {m: pooled([every_pixel], m) for m in ("network", "top_down")},
                "versus_kept": {m: paired_first_attempts([judged], [every_pixel], m) for m in ("network", "top_down")}}

    def verdict(*runs: dict) -> str:
        return drop_section({"command": "c", "date": "d", "machine": "m", "block": 24, "runs": list(runs)})[-1]

    more, same, less = (_set("household", n, [False] * 8) for n in ([True] * 8, [False] * 4 + [True] * 4, [False] * 8))
    kept = "Dropping flying pixels from the depth image: **kept** at 5 mm"
    assert verdict(run(0.005, 1.0, 24, more), run(0.005, 0.0, 24, same)).startswith(kept)
    assert verdict(run(0.005, 1.0, 24, more), run(0.005, 0.0, 24, less)).startswith(kept.replace("**kept** at 5 mm",
                                                                                                  "**not kept**"))
    assert verdict(run(0.005, 1.0, 24, more), run(0.005, 1.0, 48, same), run(0.005, 0.0, 24, same)).startswith(
        "Dropping flying pixels from the depth image: **not kept**")  # the run at the most views decides
    assert verdict(run(0.01, 1.0, 24, same), run(0.01, 0.0, 24, same), run(0.005, 1.0, 24, more),
                   run(0.005, 0.0, 24, same)).startswith(kept)
    alone = verdict(run(0.005, 1.0, 24, more))
    assert "**not kept**" in alone and "under flying pixels (24 views), not judged on exact depth" in alone
    lines = drop_section({"command": "c", "date": "d", "machine": "m", "block": 24,
                          "runs": [run(0.005, 1.0, 24, more)]})
    assert "| 5 mm | 1 | 24 | 100% | 50% | +50.0 points [+12.5, +87.5] | 0% | 0% | +0.0 points [+0.0, +0.0] |" in lines
