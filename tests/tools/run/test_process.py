"""What an app process needs around its core (``run.process``): its log (real MCAP files, with
the Foxglove views or without, in this process or a child), its clock, its signing key, and a
SIGTERM that lets it close its log."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from ridsafe.common import topics
from ridsafe.common.clock import EpochClock, MonotonicClock
from ridsafe.common.codec import signing_timestamp_from_unix
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import NullSink
from ridsafe.tools.run import process
from ridsafe.tools.runlog.child_writer import RecorderProcess
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder
from tests.tools.runlog.mcap_files import ORIGIN, truth_record

ORIGIN_POINT = GeodeticOrigin(**ORIGIN)


def _topics_written(path: Path) -> set[str]:
    return {topic for topic, _t, _r in read_records(path)}


@pytest.mark.parametrize("child_process", [False, True])
@pytest.mark.parametrize("foxglove", [False, True])
def test_the_run_log_has_the_foxglove_views_when_asked(
    tmp_path: Path, child_process: bool, foxglove: bool
) -> None:
    path = tmp_path / "deep" / "run.mcap"  # folders are made
    log = process.open_run_log(path, ORIGIN_POINT, foxglove, child_process=child_process)
    assert isinstance(log, RecorderProcess if child_process else McapRecorder)
    with log as sink:
        sink.log(topics.TRUTH, 0.0, truth_record(0.0))
    written = _topics_written(path)
    assert topics.TRUTH in written
    assert ("/foxglove/location/1" in written) is foxglove  # the origin reached the plug-in


def test_an_app_without_log_drops_its_records(tmp_path: Path) -> None:
    assert isinstance(process.open_sink(None, ORIGIN_POINT), NullSink)
    sink = process.open_sink(tmp_path / "app.mcap", ORIGIN_POINT, foxglove=False)
    sink.log(topics.TRUTH, 0.0, truth_record(0.0))
    process.close_sink(sink)
    process.close_sink(NullSink())  # nothing to close: fine
    assert _topics_written(tmp_path / "app.mcap") == {topics.TRUTH}


def test_the_clock_starts_now_or_at_the_shared_instant() -> None:
    assert isinstance(process.make_clock(2.0, None), MonotonicClock)
    shared = process.make_clock(4.0, time.time() - 1.0)
    assert isinstance(shared, EpochClock)
    assert shared.now_s() == pytest.approx(4.0, abs=0.4)  # 1 wall second ago at 4x


def test_signing_from_a_key_file_starts_at_the_wall_clock(tmp_path: Path) -> None:
    assert process.signing_from_file(None) is None
    key_file = tmp_path / "mavlink.key"
    key_file.write_text("ab" * 32)
    before = signing_timestamp_from_unix(time.time())
    signing = process.signing_from_file(key_file)
    assert signing is not None and signing.key == bytes.fromhex("ab" * 32)
    assert before <= signing.initial_timestamp <= signing_timestamp_from_unix(time.time())


def test_sigterm_calls_stop_and_the_old_handler_comes_back() -> None:
    stopped: list[bool] = []
    previous = signal.getsignal(signal.SIGTERM)
    restore = process.stop_on_sigterm(lambda: stopped.append(True))
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        deadline = time.monotonic() + 5.0
        while not stopped and time.monotonic() < deadline:
            time.sleep(0.01)  # the handler runs between bytecodes of this thread
    finally:
        restore()
    assert stopped == [True]
    assert signal.getsignal(signal.SIGTERM) == previous


def test_a_stop_request_cuts_the_wait_for_the_start_short() -> None:
    stop = process.StopRequest()
    stopped: list[str] = []
    stop.set()  # before anything runs, as a SIGTERM during the start-up
    stop.forward_to(lambda: stopped.append("runner"))  # forwarded at once
    start = time.monotonic()
    process.wait_for_start(time.time() + 30.0, 1.0, "gcs", stop)
    assert time.monotonic() - start < 2.0
    assert stopped == ["runner"]
    stop.set()  # and again later: every forward target hears it
    assert stopped == ["runner", "runner"]


def _affinity() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({}, None),  # no cgroup files: the affinity mask alone
        ({"cpu.max": "max 100000\n"}, None),  # v2, no limit
        ({"cpu.max": "50000 100000\n"}, 1),  # v2, half a CPU: one
        ({"cpu.max": "150000 100000\n"}, 2),  # v2, 1.5 CPUs: two (rounded up)
        ({"cpu/cpu.cfs_quota_us": "-1\n", "cpu/cpu.cfs_period_us": "100000\n"}, None),  # v1
        ({"cpu/cpu.cfs_quota_us": "100000\n", "cpu/cpu.cfs_period_us": "100000\n"}, 1),
        ({"cpu.max": "garbage\n"}, None),  # unreadable: no limit assumed
    ],
)
def test_usable_cpus_is_the_affinity_mask_within_the_cgroup_quota(
    tmp_path: Path, files: dict[str, str], expected: int | None
) -> None:
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    want = _affinity() if expected is None else min(expected, _affinity())
    assert process.usable_cpus(tmp_path) == want
