"""A record's items held as columns (``logsink.ItemRows``): they read, compare, pickle and
are written to the run log as the list of dicts they stand for, and a NaN among them is
still counted and written as null."""

from __future__ import annotations

import math
import pickle
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.common.logsink import ItemRows, plain_record
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder

KEYS = ("sender", "receiver", "rssi_dbm")
COLUMNS = ([1, 1, 2], [2, 3, 1], [-70.5, -81.0, -64.25])
AS_DICTS = [
    {"sender": 1, "receiver": 2, "rssi_dbm": -70.5},
    {"sender": 1, "receiver": 3, "rssi_dbm": -81.0},
    {"sender": 2, "receiver": 1, "rssi_dbm": -64.25},
]


def test_item_rows_read_as_their_list_of_dicts() -> None:
    rows = ItemRows(KEYS, COLUMNS)
    assert len(rows) == 3 and list(rows) == AS_DICTS and rows == AS_DICTS
    assert rows[1] == AS_DICTS[1] and rows[-1] == AS_DICTS[-1] and rows[:2] == AS_DICTS[:2]
    assert [list(d) for d in rows] == [list(KEYS)] * 3  # the keys in order
    assert len(ItemRows((), ())) == 0


def test_item_rows_pickle_as_columns_and_unpickle_as_the_plain_list() -> None:
    rows = ItemRows(KEYS, COLUMNS)
    back = pickle.loads(pickle.dumps({"items": rows}, pickle.HIGHEST_PROTOCOL))
    assert type(back["items"]) is list and back["items"] == AS_DICTS
    record = {"sysid": 3, "items": rows}
    assert plain_record(record) == {"sysid": 3, "items": AS_DICTS}
    assert type(plain_record(record)["items"]) is list
    plain = {"sysid": 3, "items": AS_DICTS}
    assert plain_record(plain) is plain


def test_any_keys_make_the_dicts_dict_and_zip_would() -> None:
    """The items are built by code written out per key set: keys that are not names (quotes,
    backslashes, code, a repeated key) come out as ``dict(zip(keys, row))`` has them."""
    keys = ("it's", 'a "b"', "back\\slash", "]} + 1 #", "ключ", "", "it's")
    columns = tuple([k, k + 0.5] for k in range(len(keys)))
    expected = [dict(zip(keys, row, strict=True)) for row in zip(*columns, strict=True)]
    assert ItemRows(keys, columns).as_list() == expected
    assert [list(item) for item in ItemRows(keys, columns)] == [list(dict.fromkeys(keys))] * 2


def test_columns_of_different_lengths_are_refused() -> None:
    with pytest.raises(ValueError, match="ItemRows"):
        ItemRows(KEYS, ([1], [2, 3], [4.0]))
    with pytest.raises(ValueError, match="ItemRows"):
        ItemRows(KEYS[:2], COLUMNS)


def test_a_recorder_in_the_same_process_writes_the_items_and_counts_a_nan(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    nan_column = [-70.5, math.nan, -64.25]
    with McapRecorder(path) as recorder:
        recorder.log(topics.RADIO_RX, 1.0, {"items": ItemRows(KEYS, COLUMNS)})
        recorder.log(topics.RADIO_RX, 2.0, {"items": ItemRows(KEYS, (*COLUMNS[:2], nan_column))})
        nonfinite = dict(recorder.nonfinite_counts)
    (_, _, first), (_, _, second) = read_records(path, {topics.RADIO_RX})
    assert first["items"] == AS_DICTS
    assert [item["rssi_dbm"] for item in second["items"]] == [-70.5, None, -64.25]
    assert nonfinite == {f"{topics.RADIO_RX}:items[].rssi_dbm": 1}
