"""The store's journal: committed writes survive a crash before they reach SQLite; a torn tail is ignored."""

from __future__ import annotations

import os
import shutil

from blackboard.core import BlackboardCore
from blackboard.store import Store
from tests.blackboard.conftest import op, post, pt


def _crash_copy(src: str, dst_dir: str) -> str:
    """Copy the database files as a crash would leave them (the process never closed the store)."""
    dst = os.path.join(dst_dir, "copy.sqlite")
    for suffix in ("", "-wal", "-bblog"):
        if os.path.exists(src + suffix):
            shutil.copyfile(src + suffix, dst + suffix)
    return dst


def test_committed_but_unsettled_writes_are_replayed(tmp_path, registry):
    path = str(tmp_path / "bb.sqlite")
    store = Store(path)
    core = BlackboardCore(store, registry)
    a = post(core, "bbt_landmark", {"name": "a"}, geometry=pt(1.0, 2.0), stamp=1.0)
    store.settle()
    b = post(core, "bbt_segment", {"index": 7}, stamp=2.0)  # journaled only
    op(core, {"op": "update", "id": a["id"], "expected_version": 1, "attrs": {"name": "a2"}})
    op(core, {"op": "pose", "parent": "local", "child": "vehicle", "pose": [1.0, 2.0, 0.5], "stamp": 4.0})
    assert store.unsettled() > 0 and os.path.getsize(store.log_path) > 0
    copy = _crash_copy(path, str(tmp_path))
    store.close()

    store2 = Store(copy)
    core2 = BlackboardCore(store2, registry)
    got = {t["id"]: t for t in core2.retrieve({})}
    assert set(got) == {a["id"], b["id"]}
    assert got[a["id"]]["version"] == 2 and got[a["id"]]["attrs"]["name"] == "a2"
    assert core2.retrieve({"geometry": {"op": "near", "geometry": pt(1.0, 2.0), "distance": 0.1}})[0]["id"] == a["id"]
    assert core2.lookup({"target": "local", "target_stamp": 4.0, "source": "vehicle", "source_stamp": 4.0})[0] == 1.0
    assert os.path.getsize(store2.log_path) == 0  # replayed into SQLite, then emptied
    # replaying what SQLite already holds changes nothing, and ids are not reused
    c = post(core2, "bbt_segment", {"index": 8})
    assert c["id"] not in got
    store2.close()


def test_a_torn_last_record_is_ignored(tmp_path, registry):
    path = str(tmp_path / "bb.sqlite")
    store = Store(path)
    core = BlackboardCore(store, registry)
    a = post(core, "bbt_segment", {"index": 1})
    copy = _crash_copy(path, str(tmp_path))
    store.close()
    with open(copy + "-bblog", "ab") as f:
        f.write(b"\x40\x00\x00\x00\x12\x34\x56\x78partial")  # a record whose write never completed
    store2 = Store(copy)
    assert [t["id"] for t in BlackboardCore(store2, registry).retrieve({})] == [a["id"]]
    store2.close()
