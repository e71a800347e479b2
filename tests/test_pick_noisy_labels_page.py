"""The labels-from-noisy-views section of docs/picks.md (benchmarks/pages/pick_noisy_labels_section.py): the noisy
labels' network paired seed for seed against the exact labels' at each noise level, kept only where it is shown to
raise picks at the labels' own noise and shown to lower them at no level."""

from __future__ import annotations


def _set(picked: list[int]) -> dict:
    """A household set of 8 views an object: object k picked at the first attempt in picked[k] of them."""
    objects = [{"name": f"o{k}", "status": "ok", "views": [{"attempts": {"network": (v < n,)}} for v in range(8)]}
               for k, n in enumerate(picked)]
    return {"name": "household", "objects": objects,
            "methods": [{"method": "network", "first_attempt": sum(picked) / 8 / len(picked)}]}


def _result(noisy_at: dict[float, list[int]], exact: list[int]) -> dict:
    levels = [{"noise": noise, "seed": seed, "labels": labels, "checkpoint": f"{labels}_{seed}.pt",
               "sets": [_set(picks)]}
              for noise, noisy in noisy_at.items() for seed in (0, 1)
              for labels, picks in (("noisy", noisy), ("exact", exact))]
    batch = {"objects": "o", "labels": 10, "success_rate": 0.3}
    return {"command": "c", "date": "d", "machine": "m", "noise": 0.002, "batches": [batch, batch], "levels": levels}


def test_noisy_labels_are_kept_only_where_they_raise_picks_at_their_own_noise_and_lower_them_at_no_level():
    from benchmarks.pages.pick_noisy_labels_section import VIEWS, noisy_labels_section

    assert VIEWS == 8
    exact, better, worse = [6, 6, 4, 4, 4, 4, 2, 2], [7, 7, 5, 5, 5, 6, 2, 2], [6, 5, 3, 3, 4, 3, 2, 2]
    kept = noisy_labels_section(_result({1e-6: exact, 0.002: better}, exact))
    assert "| 2 mm | 0 | noisy | 60.9% | - |" in kept and "| 2 mm | 1 | exact | 50.0% | - |" in kept
    assert next(line for line in kept if line.startswith("- 2 mm")).startswith("- 2 mm: +10.9 points [+")
    assert "- 0.001 mm: +0.0 points [+0.0, +0.0] over 2 seeds" in kept
    assert "**kept**" in kept[-1]
    hurt = noisy_labels_section(_result({1e-6: worse, 0.002: better}, exact))
    assert "**not kept**: it lowers the first attempt at 0.001 mm" in hurt[-1]
    unshown = noisy_labels_section(_result({1e-6: exact, 0.002: exact}, exact))
    assert "**not kept**: its interval at the labels' own noise reaches zero" in unshown[-1]
