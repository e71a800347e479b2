import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import zarr

from onepiece_dist.errors import StoreError
from onepiece_dist.runtime.local import run_local
from onepiece_dist.store import PartStore, open_dataset
from onepiece_dist.store.dataset import content_digest

ROOT = Path(__file__).resolve().parents[1]


def part_arrays(n=5):
    rng = np.random.default_rng(n)
    return {"code": rng.integers(0, 255, (n, 8), dtype=np.uint8), "width": rng.random(n).astype(np.float32)}


def test_part_commit_is_idempotent(tmp_path):
    parts = PartStore(tmp_path)
    assert parts.write("k1", part_arrays(), {"grasps": 5}) is True
    assert parts.write("k1", part_arrays(9), {"grasps": 9}) is False  # a retried writer changes nothing
    assert parts.read_meta("k1")["grasps"] == 5
    assert np.array_equal(parts.read("k1")["code"], part_arrays()["code"])
    assert parts.committed_keys() == ["k1"]


def test_crash_mid_write_leaves_no_committed_part(tmp_path, monkeypatch, record_figure):
    parts = PartStore(tmp_path)
    import onepiece_dist.store.parts as mod

    def explode(group, name, data, rows=0):
        if name == "width":
            raise OSError("disk full")
        return original(group, name, data)

    original = mod.write_array
    monkeypatch.setattr(mod, "write_array", explode)
    with pytest.raises(OSError):
        parts.write("k1", part_arrays(), {"grasps": 5})
    assert not parts.is_committed("k1") and parts.committed_keys() == []
    assert not list(tmp_path.iterdir())  # the temporary folder was cleaned up
    with pytest.raises(KeyError):
        parts.read("k1")
    record_figure(f"{len(parts.committed_keys())} committed parts and {len(list(tmp_path.iterdir()))} temporaries "
                  "after a crash mid-write")


def test_temporaries_of_gone_writers_are_removed_and_those_of_live_ones_kept(tmp_path, record_figure):
    import json
    import time

    from onepiece_dist.store.parts import OWNER_FILE, STALE_AFTER_S, this_process

    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)

    def temporary(name: str, owner: dict | None) -> None:
        (tmp_path / name).mkdir()
        if owner is not None:
            (tmp_path / name / OWNER_FILE).write_text(json.dumps(owner))

    temporary(".tmp-k1-dead", {**this_process(), "pid": int(ended.stdout)})  # its writer has exited
    temporary(".tmp-k2-live", this_process())  # this process, still writing
    temporary(".tmp-k3-elsewhere", {**this_process(), "host": "another-host"})  # cannot be checked: waits
    temporary(".tmp-k4-unknown", None)
    parts = PartStore(tmp_path)
    assert parts.remove_stale_temporaries() == 1 and not (tmp_path / ".tmp-k1-dead").exists()
    assert parts.remove_stale_temporaries(now=time.time() + STALE_AFTER_S + 1) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [".tmp-k2-live"]
    record_figure("1 of 4 temporaries removed at once (writer ended), 2 more after 6 h, the live writer's kept")


def test_a_job_starting_on_a_shared_cache_leaves_another_jobs_part_write_alone(tmp_path, monkeypatch, record_figure):
    import threading

    import onepiece_dist.store.parts as mod

    original, inside, release = mod.write_array, threading.Event(), threading.Event()

    def paused(group, name, data, rows=8192):
        if name == "width":  # job 1 is in the middle of its part
            inside.set()
            assert release.wait(30)
        return original(group, name, data)

    monkeypatch.setattr(mod, "write_array", paused)
    writer = threading.Thread(target=lambda: PartStore(tmp_path).write("k1", part_arrays(), {"grasps": 5}))
    writer.start()
    assert inside.wait(30)
    assert PartStore(tmp_path).remove_stale_temporaries() == 0  # job 2 starts on the same cache
    release.set()
    writer.join(30)
    committed = PartStore(tmp_path)
    assert committed.is_committed("k1") and set(committed.read("k1")) == {"code", "width"}
    assert np.array_equal(committed.read("k1")["width"], part_arrays()["width"])
    assert not list(tmp_path.glob(".tmp-*"))
    record_figure("0 temporaries removed under a paused writer; its part committed complete")


def test_dataset_round_trip_and_incomplete_refusal(spec_factory):
    spec = spec_factory()
    status = run_local(spec)
    assert status.state == "succeeded"
    ds = open_dataset(spec.output)
    codes, index, unique = ds["grasps/code"], ds["grasps/code_index"], ds["unique/code"]
    assert len(codes) == status.progress.grasps > 0 and len(unique) == status.progress.unique_codes
    assert np.array_equal(unique[index], codes) and ds["unique/count"].sum() == len(codes)
    assert ds["grasps/object"].max() == len(ds.object_names) - 1
    assert ds.attrs["provenance"]["seed"] == spec.seed
    zarr.open_group(spec.output, mode="a").attrs["complete"] = False
    with pytest.raises(StoreError, match="incomplete"):
        open_dataset(spec.output)


def test_same_spec_and_seed_give_identical_arrays(spec_factory, tmp_path, record_figure):
    a = spec_factory(output=str(tmp_path / "a.zarr"))
    b = spec_factory(output=str(tmp_path / "b.zarr"))
    run_local(a), run_local(b)
    da, db = open_dataset(a.output), open_dataset(b.output)
    for name in ("grasps/code", "grasps/pose", "grasps/code_index", "unique/code", "unique/count"):
        assert np.array_equal(da[name], db[name]), name
    assert content_digest(a.output) == content_digest(b.output)
    record_figure(f"two runs of one spec and seed: the same content digest ({content_digest(a.output)[:12]})")


def test_example_reader_uses_only_zarr_and_numpy(spec_factory):
    spec = spec_factory()
    run_local(spec)
    script = ROOT / "examples" / "read_dataset_with_zarr.py"
    assert "import onepiece_dist" not in script.read_text() and "from onepiece_dist" not in script.read_text()
    out = subprocess.run([sys.executable, str(script), spec.output], capture_output=True, text=True, check=True)
    assert "unique codes" in out.stdout


def test_content_digest_sees_every_array_and_content_attribute_but_not_where_or_when(tmp_path):
    from onepiece_dist.store.dataset import ObjectTable, content_digest, write_dataset

    def dataset(name: str, width: float, seconds: float, label: str = "a") -> str:
        path = str(tmp_path / name)
        write_dataset(path, {"job_spec": {"output": path, "seed": 1}, "stats": {"seconds": seconds}, "tag": label},
                      ObjectTable(["o"], ["00" * 16], np.array([1])),
                      {"grasps": {"width": np.array([width], np.float32)}, "train": {"loss": np.ones(2)}})
        return path

    base = content_digest(dataset("a.zarr", 0.1, 1.0))
    assert content_digest(dataset("b.zarr", 0.1, 9.0)) == base  # other path, other timing: same content
    assert content_digest(dataset("c.zarr", 0.2, 1.0)) != base  # one float changed
    assert content_digest(dataset("d.zarr", 0.1, 1.0, "b")) != base  # one content attribute changed
    zarr.open_group(str(tmp_path / "a.zarr"), mode="a")["train/loss"][0] = 2.0
    assert content_digest(str(tmp_path / "a.zarr")) != base
    assert content_digest(str(tmp_path / "a.zarr"), training=False) == content_digest(
        str(tmp_path / "b.zarr"), training=False)
