"""The committed studies (docs/studies/): each page is the rendering of its result and each result's spec its
example's; the picks study's page says how it judged (a study run end to end: tests/test_study.py)."""

from __future__ import annotations

import json
from pathlib import Path

from onepiece_dist.study.spec import load_study_spec

ROOT = Path(__file__).resolve().parents[1]


def rendered_again(name: str, folder: Path):
    """The committed study ``docs/studies/NAME``'s result, its page rendered again in ``folder``, and its spec as
    the example of the same name gives it."""
    import shutil

    from onepiece_dist.study.runner import report_study

    committed = ROOT / "docs" / "studies" / name
    shutil.copy(committed / "study.json", folder / "study.json")
    result = report_study(folder)
    assert (folder / "study.md").read_text() == (committed / "study.md").read_text()
    assert result.spec == load_study_spec(ROOT / "examples" / "studies" / f"{name}.yaml", {})
    return result


def test_the_committed_quick_study_page_is_the_rendering_of_its_result(tmp_path):
    result = rendered_again("quick", tmp_path)
    assert {arm.kind for arm in result.arms} == {"A", "B", "R"} and result.wall_seconds < 600


def test_the_committed_force_closure_study_is_the_paper_force_closure_example_and_its_page_its_rendering(tmp_path):
    """Issue 40: the full-size study under force closure, committed with its premise, lookup and label figures."""
    result = rendered_again("paper_force_closure", tmp_path)
    assert result.train_objects == 64 and result.heldout.objects == 64 and len(result.premise) == 3
    assert result.label_fit is not None and result.lookup is not None


def test_the_committed_key_study_is_its_example_and_measures_every_key_beside_the_jobs_own_code(tmp_path):
    """Issue 38 item 6: the key study as a study configuration, committed with every key's lookup."""
    result = rendered_again("key_study", tmp_path)
    assert [key.name for key in result.keys] == [key.name for key in result.spec.keys] and len(result.keys) == 8
    own = result.keys[0]
    assert own.lookup == result.lookup  # the job's 10 mm code, recomputed from the settled crops
    assert result.train_objects == 64 and result.heldout.objects == 48


def test_the_committed_key_study_extended_with_u_reused_the_key_studys_work_and_says_its_targets(tmp_path):
    """Issue 39 under the physics label, at the key study's size: `--extend` on the committed key study's folder."""
    result = rendered_again("key_study_adaptive", tmp_path)
    keys = json.loads((ROOT / "docs" / "studies" / "key_study" / "study.json").read_text())
    assert set(result.reused_jobs) == {"heldout", "A", "B r0"} and result.reused_runs >= 20
    shared = {arm["name"]: arm["heldout"] for arm in keys["arms"]}
    assert {arm.name for arm in result.arms} & set(shared) >= {"A", "B r0"}  # all() over none would pass
    assert all(arm.heldout.model_dump(mode="json") == shared[arm.name] for arm in result.arms if arm.name in shared)
    assert result.adaptive and result.decision.u_met is not None
    assert "Target for U" in (tmp_path / "study.md").read_text()


def test_the_picks_table_says_how_the_held_out_candidates_were_made():
    """Issue 58: the committed picks study proposes its candidates on views; its page said the full mesh."""
    from onepiece_dist.study.page import picks_table
    from onepiece_dist.study.result import StudyResult

    result = StudyResult.model_validate_json((ROOT / "docs" / "studies" / "picks" / "study.json").read_text())
    assert result.spec.views and result.spec.view_sampling == "view"

    def table(**spec: object) -> str:
        return "\n".join(picks_table(result.model_copy(update={"spec": result.spec.model_copy(update=spec)})))

    assert "proposed on each held-out view's cloud" in table() and "mesh" not in table()
    assert "each cropped from its nearest view" in table(view_sampling="mesh")
    assert "candidates sampled on the full mesh" in table(views=0)


def test_the_committed_picks_study_answers_by_picks_and_against_the_label_ceiling_first(tmp_path):
    """Issue 51: the committed study on held-out household meshes, judged by picks and by candidates; its page's
    first lines give the cheapest plan inside A by pick success, by how much, and where A stands against the
    label's ceiling. Its spec is the example's but for the held-out objects (a folder of this machine's)."""
    import shutil

    from onepiece_dist.study.runner import report_study

    committed = ROOT / "docs" / "studies" / "picks"
    shutil.copy(committed / "study.json", tmp_path / "study.json")
    result = report_study(tmp_path)
    page = (tmp_path / "study.md").read_text()
    assert page == (committed / "study.md").read_text()
    spec = result.spec
    assert spec == load_study_spec(ROOT / "examples" / "studies" / "picks.yaml", {"heldout": spec.heldout})
    assert "household" in spec.heldout and result.heldout.objects >= 32 and result.train_objects >= 60
    first = page.splitlines()[2]
    assert first.startswith("**Judged by picks.**") and f"is **{result.picks.cheapest}**" in first
    assert result.picks.cheapest == "A" or "points)" in first  # by how much
    first_lines = page.split("## Arms")[0].splitlines()
    assert any("**" in line and "of the way from the floor to the ceiling" in line for line in first_lines)
    assert any(line.startswith("**Labels to reach a pick level**") for line in first_lines)
    assert {arm.name for arm in result.picks.arms} == {arm.name for arm in result.arms}
