"""Tests of merging the part logs of a live run into one run log."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from ridsafe.common import topics
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels
from ridsafe.tools.runlog.merge import merge_parts
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder
from tests.tools.runlog.mcap_files import (
    ORIGIN,
    by_topic,
    cycle,
    raw_messages,
    region_record,
    rotated_cov,
    truncated_copy,
    truth_record,
    write_cycles,
)


def test_merge_keeps_every_readable_message_in_time_order(tmp_path: Path) -> None:
    # Part A (complete): cycles at 0, 0.5, 1.0, ...; part B (cut off): decisions at 0.25, 0.75
    # ... and a cycle at 1.0 (a tie with A); part C: garbage.
    part_a = tmp_path / "gcs.mcap"
    with McapRecorder(part_a) as recorder:
        for k in range(400):
            recorder.log(topics.GCS_CYCLE, 0.5 * k, cycle(k))
    full_b = tmp_path / "companion_full.mcap"
    with McapRecorder(full_b, chunk_size=2048) as recorder:
        recorder.log(topics.GCS_CYCLE, 1.0, {**cycle(0), "from": "b"})
        for k in range(400):
            recorder.log(topics.DECISIONS, 0.25 + 0.5 * k, {"sysid": 1, "compute_ms": 1.0 * k})
    part_b = truncated_copy(full_b, tmp_path / "companion.mcap", full_b.stat().st_size // 2)
    part_c = tmp_path / "sim.mcap"
    part_c.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 5)

    readable_a = list(read_records(part_a))
    readable_b = list(read_records(part_b))
    assert 0 < len(readable_b) < 401
    out = tmp_path / "run.mcap"
    report = merge_parts([part_a, part_b, part_c], out)

    assert [(p.path, p.messages, p.complete) for p in report.parts] == [
        (part_a, 400, True),
        (part_b, len(readable_b), False),
        (part_c, 0, False),
    ]
    assert report.parts[2].error is not None
    assert not report.complete
    merged = list(read_records(out))
    assert report.messages == len(merged) == len(readable_a) + len(readable_b)
    assert sorted(map(repr, merged)) == sorted(map(repr, readable_a + readable_b))
    times = [t for _topic, t, _r in merged]
    assert times == sorted(times)
    at_one = [r for _topic, t, r in merged if t == 1.0 and _topic == topics.GCS_CYCLE]
    assert [r.get("from") for r in at_one] == [None, "b"]  # ties keep the parts' order
    with open(out, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    channel_topics = [c.topic for c in summary.channels.values()]
    assert sorted(channel_topics) == sorted({topics.GCS_CYCLE, topics.DECISIONS})


def test_merge_refuses_to_overwrite_a_part(tmp_path: Path) -> None:
    part = tmp_path / "a.mcap"
    write_cycles(part, 3)
    with pytest.raises(ValueError, match="also one of the parts"):
        merge_parts([part], part)


def test_merge_keeps_one_copy_of_identical_derived_messages(tmp_path: Path) -> None:
    sim, gcs = tmp_path / "sim.mcap", tmp_path / "gcs.mcap"
    with McapRecorder(sim, plugins=[FoxgloveChannels(GeodeticOrigin(**ORIGIN))]) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    with McapRecorder(gcs, plugins=[FoxgloveChannels()]) as recorder:
        recorder.log(topics.REGIONS, 0.25, region_record(rotated_cov()))
    report = merge_parts([sim, gcs], tmp_path / "run.mcap")
    grouped = by_topic(raw_messages(tmp_path / "run.mcap"))
    assert len(grouped["/foxglove/tf"]) == 1  # both parts wrote the same transform
    assert report.duplicates_dropped == 1
    assert report.messages == report.parts[0].messages + report.parts[1].messages - 1
