"""Tests of the run-log writer: real MCAP files, read back with the ``mcap`` library's own
reader where the test is about the file format, and with ``read_records`` where it is about
what the project reads."""

from __future__ import annotations

import enum
import json
import logging
import math
import shutil
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from mcap.reader import make_reader

from ridsafe.common import topics
from ridsafe.common.logsink import Record
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import (
    METADATA_NAME,
    DerivedChannels,
    McapRecorder,
    RecorderError,
    derived_bytes,
)
from tests.tools.runlog.mcap_files import cycle, raw_messages


def test_round_trip_through_a_real_mcap_file(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    decision = {
        "sysid": np.int64(3),
        "planner": "spoofing_aware ✈",
        "status": "cruise",
        "target_p_ned_m": np.array([1.5, -2.25, -60.0]),
        "target_v_ned_m_s": (1.0, 0.0, 0.0),
        "target_lat_deg": 36.14471234567,
        "target_lon_deg": -86.80271234567,
        "target_alt_m": np.float32(240.5),
        "compute_ms": 0.8125,
        "n_neighbours": 4,
        "n_regions": 0,
    }
    with caplog.at_level(logging.WARNING), McapRecorder(path) as recorder:
        recorder.log(topics.GCS_CYCLE, 0.25, cycle(1))
        recorder.log(topics.DECISIONS, 0.5, decision)
        recorder.log("/custom/thing", 0.75, {"t_s": 99.0, "x": [1, 2]})  # its own t_s
        recorder.log("/custom/thing", 1.0, {})
        recorder.log(topics.GCS_CYCLE, 1.25, cycle(2))
    assert "/custom/thing" in caplog.text  # unknown topic: one warning
    assert caplog.text.count("/custom/thing: not in") == 1

    messages = raw_messages(path)
    assert [m["topic"] for m in messages] == [
        topics.GCS_CYCLE,
        topics.DECISIONS,
        "/custom/thing",
        "/custom/thing",
        topics.GCS_CYCLE,
    ]
    for m in messages:
        assert m["message_encoding"] == "json"
        assert m["schema_encoding"] == "jsonschema"
        assert m["log_time"] == m["publish_time"]
    assert [m["log_time"] for m in messages] == [
        250_000_000,
        500_000_000,
        750_000_000,
        1_000_000_000,
        1_250_000_000,
    ]
    assert messages[0]["schema"] == topics.schema(topics.GCS_CYCLE)
    assert messages[0]["schema_name"] == topics.GCS_CYCLE
    assert messages[2]["schema"] == {"title": "/custom/thing", "type": "object"}
    assert messages[0]["data"] == {"t_s": 0.25, **cycle(1)}
    assert next(iter(messages[0]["data"])) == "t_s"
    assert messages[1]["data"] == {
        "t_s": 0.5,
        **decision,
        "sysid": 3,
        "target_p_ned_m": [1.5, -2.25, -60.0],
        "target_v_ned_m_s": [1.0, 0.0, 0.0],
        "target_alt_m": 240.5,
    }
    assert messages[2]["data"] == {"t_s": 99.0, "x": [1, 2]}
    assert messages[3]["data"] == {"t_s": 1.0}
    # one channel per topic
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert sorted(c.topic for c in summary.channels.values()) == sorted(
        [topics.GCS_CYCLE, topics.DECISIONS, "/custom/thing"]
    )
    assert summary.statistics.message_count == 5


def test_non_finite_numbers_become_null_and_are_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    track = {"uas_id": "X", "p_enu_m": [1.0, math.nan, 2.0], "cov_enu_m2": [[math.inf]]}
    with caplog.at_level(logging.WARNING), McapRecorder(path) as recorder:
        recorder.log(topics.TRACKS, 1.0, track)
        recorder.log(topics.TRACKS, 2.0, {**track, "items": [{"v": -math.inf}, {"v": 1.0}]})
        counts = recorder.nonfinite_counts
    assert counts == {
        "/gcs/tracks:p_enu_m[]": 2,
        "/gcs/tracks:cov_enu_m2[][]": 2,
        "/gcs/tracks:items[].v": 1,
    }
    assert caplog.text.count("/gcs/tracks:p_enu_m[]") == 1  # warned once per field
    records = [r for _topic, _t, r in read_records(path)]
    assert records[0] == {
        "t_s": 1.0,
        "uas_id": "X",
        "p_enu_m": [1.0, None, 2.0],
        "cov_enu_m2": [[None]],
    }
    assert records[1]["items"] == [{"v": None}, {"v": 1.0}]
    raw_messages(path)  # strict JSON parse: no NaN / Infinity constants anywhere
    with open(path, "rb") as stream:
        (metadata,) = [m for m in make_reader(stream).iter_metadata() if m.name == METADATA_NAME]
    assert json.loads(metadata.metadata["nonfinite_nulled"]) == counts


def test_unserialisable_value_is_an_error_naming_topic_and_field(tmp_path: Path) -> None:
    with (
        McapRecorder(tmp_path / "run.mcap") as recorder,
        pytest.raises(RecorderError, match=r"/x/y: field a\.b\[1\] \(set\)"),
    ):
        recorder.log("/x/y", 0.0, {"a": {"b": [1, {2, 3}]}})


@pytest.mark.parametrize("t_s", [-0.1, math.nan, math.inf])
def test_bad_sim_time_is_rejected(tmp_path: Path, t_s: float) -> None:
    with (
        McapRecorder(tmp_path / "run.mcap") as recorder,
        pytest.raises(RecorderError, match="sim time"),
    ):
        recorder.log(topics.GCS_CYCLE, t_s, cycle(0))


def test_close_is_idempotent_and_log_after_close_fails(tmp_path: Path) -> None:
    recorder = McapRecorder(tmp_path / "run.mcap")
    recorder.log(topics.GCS_CYCLE, 0.0, cycle(0))
    recorder.close()
    recorder.close()
    with pytest.raises(RecorderError, match="after close"):
        recorder.log(topics.GCS_CYCLE, 1.0, cycle(1))
    assert len(raw_messages(tmp_path / "run.mcap")) == 1


def test_flush_every_s_bounds_what_a_crash_loses(tmp_path: Path) -> None:
    copies = {}
    for flush_every_s in (1.0, None):
        path = tmp_path / f"run{flush_every_s}.mcap"
        recorder = McapRecorder(path, chunk_size=1 << 22, flush_every_s=flush_every_s)
        for k in range(46):
            recorder.log(topics.GCS_CYCLE, 0.1 * k, cycle(k))  # up to t = 4.5 s
        copies[flush_every_s] = shutil.copyfile(path, tmp_path / f"crash{flush_every_s}.mcap")
        recorder.close()
    flushed = [t for _topic, t, _r in read_records(copies[1.0])]
    assert flushed == pytest.approx([0.1 * k for k in range(41)])  # up to the flush at 4.0 s
    assert list(read_records(copies[None])) == []  # one big open chunk: everything lost


# --------------------------------------------------------------------------------------------
# Plug-ins: derived channels


class CountingPlugin:
    """Derives ``/derived/count`` (how many cycles so far) from every ``/gcs/cycle``."""

    topics: Collection[str] = (topics.GCS_CYCLE,)
    schema: ClassVar[dict[str, object]] = {"title": "count", "type": "object"}

    def __init__(self) -> None:
        self.n = 0

    def on_record(self, topic: str, t_s: float, record: Record, out: DerivedChannels) -> None:
        self.n += 1
        out.write_derived("/derived/count", "count", self.schema, t_s, {"n": self.n})
        if record["n_observations"] == 2:
            raise KeyError("a record this plug-in cannot view")


def test_a_plugin_writes_its_channel_after_each_record_it_sees(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    with caplog.at_level(logging.WARNING), McapRecorder(path, plugins=[CountingPlugin()]) as rec:
        for k in range(4):
            rec.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
            rec.log(topics.DECISIONS, 0.25 * k, {"sysid": 1, "compute_ms": 1.0})
    messages = raw_messages(path)
    first = [m["topic"] for m in messages[:3]]
    assert first == [topics.GCS_CYCLE, "/derived/count", topics.DECISIONS]
    derived = [m for m in messages if m["topic"] == "/derived/count"]
    assert [m["data"] for m in derived] == [{"n": 1}, {"n": 2}, {"n": 3}, {"n": 4}]
    assert [m["log_time"] for m in derived] == [0, 250_000_000, 500_000_000, 750_000_000]
    assert derived[0]["schema_name"] == "count" and derived[0]["schema"] == CountingPlugin.schema
    assert caplog.text.count("no derived view") == 1  # the plug-in's error cost only its view
    assert len([m for m in messages if m["topic"] == topics.GCS_CYCLE]) == 4


class _Detector(enum.IntEnum):
    MLAT = 5


class _Frozen(Mapping[str, float]):
    """A mapping that is not a dict."""

    def __getitem__(self, key: str) -> float:
        return {"a": 1.5}[key]

    def __iter__(self) -> Iterator[str]:
        return iter(["a"])

    def __len__(self) -> int:
        return 1


def test_every_record_reads_back_as_the_standard_librarys_encoding_would(
    tmp_path: Path,
) -> None:
    """The fast encoder (orjson) against ``json`` on what runs log and on what it would treat
    differently: the same values come back from the file, byte for byte or not."""
    wide = np.arange(12.0).reshape(3, 4)
    records: list[dict[str, Any]] = [
        {"small": 3.639023921104139e-05, "tiny": 1e-300, "big": 1.5e300, "neg": -0.0},
        {"keys": {1: 0.19, 16: -0.51}, "flags": {True: "yes", None: "no", 2.5: "x"}},
        {"f32": np.float32(0.1), "f32s": np.array([0.1, 0.2], dtype=np.float32)},
        {"column": wide[:, 1], "ints": np.arange(3), "flag": np.bool_(True), "n": np.int64(7)},
        {"tuple": (1, (2.5, "a")), "enum": _Detector.MLAT, "mapping": _Frozen()},
        {"beyond_64_bits": 2**70, "text": "spoofing_aware ✈ \u2028", "none": None},
        {"items": [{"sender": k, "rssi_dbm": -60.0 - k / 7} for k in range(50)]},
    ]
    path = tmp_path / "run.mcap"
    with McapRecorder(path) as recorder:
        for k, record in enumerate(records):
            recorder.log("/custom/thing", float(k), record)
        assert recorder.nonfinite_counts == {}
    expected = [
        json.loads(json.dumps({"t_s": float(k), **record}, default=_plain))
        for k, record in enumerate(records)
    ]
    assert [m["data"] for m in raw_messages(path)] == expected
    assert [r for _topic, _t, r in read_records(path)] == expected


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return dict(value)


def test_a_null_that_was_none_is_no_non_finite_number(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with McapRecorder(path) as recorder:
        recorder.log(topics.GCS_CYCLE, 0.25, {**cycle(1), "error": None})
        recorder.log(topics.GCS_CYCLE, 0.5, {**cycle(2), "error": None, "x": np.array([np.nan])})
        recorder.log(topics.GCS_CYCLE, 0.75, {"error": None, "v": [None, -math.inf, 2.0]})
        recorder.log(topics.GCS_CYCLE, 1.0, {"error": None, "huge": [1e308, 1e308]})  # sum: inf
        rows = {"error": None, "p": [[1.0, 2.0], [3.0, math.nan]], "keys": [{1: 2.0, 3: math.nan}]}
        recorder.log(topics.GCS_CYCLE, 1.25, rows)  # a NaN in rows, one in a mapping's values
        counts = recorder.nonfinite_counts
    assert counts == {
        f"{topics.GCS_CYCLE}:x[]": 1,
        f"{topics.GCS_CYCLE}:v[]": 1,
        f"{topics.GCS_CYCLE}:p[][]": 1,
        f"{topics.GCS_CYCLE}:keys[].3": 1,
    }
    records = [r for _topic, _t, r in read_records(path)]
    assert [r["error"] for r in records] == [None] * 5
    assert records[4]["p"] == [[1.0, 2.0], [3.0, None]]
    assert records[4]["keys"] == [{"1": 2.0, "3": None}]
    assert records[2]["v"] == [None, None, 2.0]
    assert records[3]["huge"] == [1e308, 1e308]


def test_a_plugins_message_is_encoded_as_a_record_and_refuses_non_finite_numbers() -> None:
    message = {"entities": [{"id": "vehicle/3", "pose": (1.5, np.float64(2.25), -0.0)}], "n": 2}
    assert json.loads(derived_bytes(message)) == json.loads(json.dumps(message, default=_plain))
    assert derived_bytes('{"already":"text"}') == b'{"already":"text"}'
    with pytest.raises(ValueError, match="Out of range float values"):
        derived_bytes({"entities": [], "x": math.nan})
