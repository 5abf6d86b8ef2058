"""Tests of the run-log reader: what was logged comes back, and a file cut off mid-write
(a crash) is readable up to its last complete chunk."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest
from mcap.writer import Writer

from ridsafe.common import topics
from ridsafe.tools.runlog.reader import LogReadError, read_records
from ridsafe.tools.runlog.writer import McapRecorder
from tests.tools.runlog.mcap_files import cycle, truncated_copy, write_cycles


def test_read_records_returns_what_was_logged(tmp_path: Path) -> None:
    logged = write_cycles(tmp_path / "run.mcap", 50)
    assert list(read_records(tmp_path / "run.mcap")) == logged
    assert list(read_records(tmp_path / "run.mcap", topics=["/nothing"])) == []


def test_a_file_cut_off_mid_write_is_readable_up_to_its_last_chunk(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    recorder = McapRecorder(path, chunk_size=4096, flush_every_s=None)
    logged = []
    for k in range(3000):
        recorder.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
        logged.append((topics.GCS_CYCLE, 0.25 * k, {"t_s": 0.25 * k, **cycle(k)}))
    partial = tmp_path / "partial.mcap"
    shutil.copyfile(path, partial)  # what a crash right now would leave: no footer
    recorder.close()

    got = list(read_records(partial))
    assert 2000 < len(got) < 3000  # all but the open chunk
    assert got == logged[: len(got)]

    size = path.stat().st_size
    previous = 0
    for cut in (size // 7, size // 3 + 5, size // 2, size - 30, size - 1):
        cut_file = truncated_copy(path, tmp_path / f"cut{cut}.mcap", cut)
        got = list(read_records(cut_file))
        assert got == logged[: len(got)]
        assert len(got) >= previous
        previous = len(got)
    assert previous == 3000  # only the summary is cut off at size - 1


def test_a_file_that_is_not_mcap_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    with pytest.raises(LogReadError, match="not an MCAP file"):
        list(read_records(bad))
    with pytest.raises(LogReadError, match="cannot open"):
        list(read_records(tmp_path / "missing.mcap"))


def test_records_orjson_refuses_are_read_as_the_standard_library_reads_them(
    tmp_path: Path,
) -> None:
    """Another writer's JSON: a NaN constant and an integer beyond 64 bits parse as before;
    what is not JSON at all is a clear error."""
    path = tmp_path / "foreign.mcap"
    bodies = [b'{"t_s":1.0,"x":NaN}', b'{"t_s":2.0,"n":%d}' % 2**70, b'{"t_s":3.0,"y":[1,2]}']
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("thing", "jsonschema", b'{"type":"object"}')
        channel = writer.register_channel("/thing", "json", schema)
        for k, body in enumerate(bodies):
            writer.add_message(channel, log_time=k, data=body, publish_time=k)
        writer.finish()
    got = list(read_records(path))
    assert [r["y"] for _topic, _t, r in got[2:]] == [[1, 2]]
    assert math.isnan(got[0][2]["x"])
    assert got[1][2]["n"] == 2**70
    broken = tmp_path / "broken.mcap"
    with open(broken, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("thing", "jsonschema", b'{"type":"object"}')
        channel = writer.register_channel("/thing", "json", schema)
        writer.add_message(channel, log_time=0, data=b'{"t_s":', publish_time=0)
        writer.finish()
    with pytest.raises(LogReadError, match="/thing: record is not JSON"):
        list(read_records(broken))
