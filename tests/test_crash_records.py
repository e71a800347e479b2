"""A worker's crash record names the item it runs, and no item between items (runtime.crashes)."""

from onepiece_dist.runtime.crashes import FATAL, IDLE, CrashLog, crashed_on


def test_the_record_names_the_running_item_and_nothing_once_it_ended(tmp_path):
    log = CrashLog(tmp_path)
    (record,) = tmp_path.glob("*.log")
    log.starting("patch", 3)
    assert record.read_text() == "patch 3\n"
    log.finished()
    assert record.read_text() == f"{IDLE}\n"
    record.write_text(f"{IDLE}\n{FATAL}\n")  # a process that dies between items crashed on none of them
    assert not crashed_on(tmp_path, "patch", 3)
    record.write_text(f"patch 4\n{FATAL}\n")
    assert crashed_on(tmp_path, "patch", 4) and not record.exists()
