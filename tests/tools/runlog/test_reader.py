"""Tests of the run-log reader: what was logged comes back, and a file cut off mid-write
(a crash) is readable up to its last complete chunk."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

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
