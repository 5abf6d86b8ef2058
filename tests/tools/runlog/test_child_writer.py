"""The recorder in a child process: the same file as in-process, errors reach the run, and
the file is finished when the run's process dies or the terminal sends Ctrl-C."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from ridsafe.common import topics
from ridsafe.tools.runlog.child_writer import RecorderProcess, ctrl_c_deferred
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels
from ridsafe.tools.runlog.reader import LogReadError, read_records
from ridsafe.tools.runlog.writer import METADATA_NAME, McapRecorder, RecorderError
from tests.signals import keyboard_interrupt_on_sigint
from tests.tools.runlog.mcap_files import (
    cycle,
    meta_record,
    raw_messages,
    region_record,
    rotated_cov,
    truth_record,
)

MCAP_MAGIC = b"\x89MCAP0\r\n"  # an MCAP file ends with it after the footer


def log_a_run(sink: Any) -> None:
    """Every kind of record a run logs: meta, truth (Foxglove scenes and fixes), regions,
    non-finite numbers, numpy-free plain records, across two recorder flush points."""
    sink.log(topics.RUN_META, 0.0, meta_record())
    for k in range(120):  # 0.0 .. 11.9 s at 10 Hz
        t_s = 0.1 * k
        sink.log(topics.TRUTH, t_s, truth_record(t_s))
        sink.log(topics.GCS_CYCLE, t_s, cycle(k))
        if k % 25 == 0:
            sink.log(topics.REGIONS, t_s, region_record(rotated_cov()))
        if k == 40:
            sink.log(topics.TRACKS, t_s, {"uas_id": "X", "p_enu_m": [1.0, math.nan, 2.0]})


def wait_for(condition: Callable[[], bool], what: str, timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)


def records_so_far(path: Path) -> int:
    """How many records a reader finds in a file being written (0 before it has any)."""
    try:
        return len(list(read_records(path)))
    except LogReadError:
        return 0


def metadata(path: Path) -> dict[str, str]:
    with open(path, "rb") as stream:
        (record,) = [m for m in make_reader(stream).iter_metadata() if m.name == METADATA_NAME]
    return dict(record.metadata)


def test_the_child_writes_what_the_in_process_recorder_writes(tmp_path: Path) -> None:
    inline, child = tmp_path / "inline.mcap", tmp_path / "child.mcap"
    with McapRecorder(inline, plugins=[FoxgloveChannels()]) as recorder:
        log_a_run(recorder)
    with RecorderProcess(child, plugins=[FoxgloveChannels()], batch_records=7) as sink:
        log_a_run(sink)
    expected = raw_messages(inline)
    assert len(expected) > 360  # the records and the Foxglove channels derived from them
    assert raw_messages(child) == expected
    assert metadata(child) == metadata(inline)
    assert json.loads(metadata(child)["nonfinite_nulled"]) == {"/gcs/tracks:p_enu_m[]": 1}


def test_a_record_is_a_snapshot_taken_when_it_is_logged(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    record = cycle(1)
    with RecorderProcess(path) as sink:
        sink.log(topics.GCS_CYCLE, 0.0, record)
        record["n_tracks"] = 99  # a core reusing its dict must not rewrite the past
    ((_topic, _t, got),) = read_records(path)
    assert got["n_tracks"] == 1


def test_a_record_json_cannot_hold_fails_the_run_and_keeps_the_rest(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    sink = RecorderProcess(path, batch_records=1)
    sink.log(topics.GCS_CYCLE, 0.0, cycle(0))
    sink.log("/x/y", 0.25, {"a": {"b": [1, {2, 3}]}})
    with pytest.raises(RecorderError, match=r"/x/y: field a\.b\[1\] \(set\)"):
        for k in range(1, 2000):  # the child has stopped reading: the pipe breaks, or close says
            sink.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
        sink.close()
    sink.close()  # idempotent after the failure
    assert [t for _topic, t, _r in read_records(path)] == [0.0]  # finished file, footer and all
    raw_messages(path)


def test_a_record_that_cannot_be_sent_is_an_error_at_once(tmp_path: Path) -> None:
    with RecorderProcess(tmp_path / "run.mcap") as sink:
        with pytest.raises(RecorderError, match=r"/x/y: record cannot be handed"):
            sink.log("/x/y", 0.0, {"f": lambda: 1})
        sink.log(topics.GCS_CYCLE, 0.0, cycle(0))
    assert len(list(read_records(tmp_path / "run.mcap"))) == 1


def test_close_is_idempotent_and_log_after_close_fails(tmp_path: Path) -> None:
    sink = RecorderProcess(tmp_path / "run.mcap")
    sink.log(topics.GCS_CYCLE, 0.0, cycle(0))
    sink.close()
    sink.close()
    with pytest.raises(RecorderError, match="after close"):
        sink.log(topics.GCS_CYCLE, 1.0, cycle(1))
    assert len(raw_messages(tmp_path / "run.mcap")) == 1


def test_ctrl_c_to_the_process_group_does_not_stop_the_child(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with RecorderProcess(path, batch_records=1) as sink:
        for k in range(25):  # past the 5 s flush point: the child writes a chunk
            sink.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
        wait_for(lambda: records_so_far(path) == 21, "the child's first flush")
        pid = sink._process.pid
        assert pid is not None
        os.kill(pid, signal.SIGINT)  # what the terminal sends every process of the group
        time.sleep(0.2)  # a child that let it through would be gone by now
        for k in range(25, 50):
            sink.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
    assert len(list(read_records(path))) == 50


def test_the_file_is_finished_when_the_runs_process_dies(tmp_path: Path) -> None:
    """A run killed mid-flight (here: os._exit) keeps everything sent up to the last flush
    point (5 s of sim time), in a complete file."""
    path = tmp_path / "run.mcap"
    script = textwrap.dedent(
        f"""
        import os
        from ridsafe.common import topics
        from ridsafe.tools.runlog.child_writer import RecorderProcess, ctrl_c_deferred
        sink = RecorderProcess({str(path)!r})
        for k in range(30):  # 0.0 .. 7.25 s: sent when 5 s is passed
            sink.log(topics.GCS_CYCLE, 0.25 * k, {{"n": k}})
        os._exit(3)
        """
    )
    done = subprocess.run([sys.executable, "-c", script], timeout=60, check=False)
    assert done.returncode == 3
    # The orphaned recorder may not have created the file yet when the run's process is gone.
    wait_for(
        lambda: path.exists() and path.read_bytes().endswith(MCAP_MAGIC),
        "the orphan to finish the file",
    )
    raw_messages(path)  # the seeking reader needs the summary and footer
    times = [t for _topic, t, _r in read_records(path)]
    assert times == pytest.approx([0.25 * k for k in range(21)])  # up to the record at 5.0 s


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="signals cannot be held")
def test_ctrl_c_during_a_send_waits_until_the_batch_is_in_the_pipe() -> None:
    sent_whole = False
    with keyboard_interrupt_on_sigint(), pytest.raises(KeyboardInterrupt), ctrl_c_deferred():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # the signal has arrived and waits
        sent_whole = True
    assert sent_whole
