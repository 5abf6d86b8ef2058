"""A lockstep run on two processes logs what the serial run logs, in the same order; a worker
that fails or dies is an error that names it, never a quietly shorter log."""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import os
import pickle
import signal
import subprocess
import sys
import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest

from ridsafe.common.logsink import LogSink, MemorySink, Record
from ridsafe.common.router import ByteRouter, Wire
from ridsafe.common.shell import Datagrams
from ridsafe.tools.cli import entry_point as cli_main
from ridsafe.tools.run import lockstep, lockstep_split
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.lockstep_split import LaneBuffer, Roles, SplitLockstep, WorkerError
from ridsafe.tools.run.scenario import load_scenario_file
from ridsafe.tools.runlog.reader import LogReadError, ReadStatus, iter_messages, read_records
from ridsafe.tools.runlog.writer import McapRecorder, RecorderError

pytestmark = pytest.mark.skipif(
    not lockstep_split.can_split(), reason="a split run needs fork and two CPUs"
)

ROOT = Path(__file__).resolve().parents[3]
#: Record fields that hold wall-clock measurements (they differ between any two runs).
WALL_CLOCK_FIELDS = {"compute_ms", "pipeline_ms", "wall_clock_s", "started_unix_s"}


def _without_wall_clock(record: Mapping[str, Any]) -> dict[str, Any]:
    return {key: value for key, value in record.items() if key not in WALL_CLOCK_FIELDS}


def test_a_split_run_logs_what_a_serial_run_logs(tmp_path: Path) -> None:
    """The default scenario (4 aircraft and the spoofer, aware planner) for 20 s: every
    record, its topic, its time and its place in the log are the serial run's."""
    loaded = load_scenario_file()
    loaded = dataclasses.replace(
        loaded, scenario=dataclasses.replace(loaded.scenario, duration_s=20.0)
    )
    logs, results = {}, {}
    for split in (False, True):
        path = tmp_path / f"split-{split}.mcap"
        results[split] = result = run_lockstep(loaded, "aware", path, split=split)
        assert result.status == "completed" and result.sim_time_s == pytest.approx(20.0)
        logs[split] = [(topic, t, _without_wall_clock(r)) for topic, t, r in read_records(path)]
    serial, split_log = logs[False], logs[True]
    # Where the ticks went, by process and phase (what bench_lockstep.py prints).
    assert results[False].phase_times_s is None
    phases = results[True].phase_times_s
    assert phases is not None
    run, worker = phases["run"], phases["worker"]
    assert {"sim", "companions", "sending", "waiting_gcs", "waiting_companions"} == set(run)
    assert {"gcs", "companions", "idle"} <= set(worker) <= {"gcs", "companions", "idle", "writing"}
    assert all(s > 0.0 for s in (*run.values(), *worker.values()))
    flight_s = results[True].wall_clock_s - results[True].build_s
    assert sum(run.values()) < flight_s and sum(worker.values()) < flight_s
    # This process's phases by the tick's place in its second: the same seconds, spread over
    # the 20 ticks of 50 ms (bench_lockstep.py --by-tick).
    assert results[False].phase_times_by_tick_s is None
    by_tick = results[True].phase_times_by_tick_s
    assert by_tick is not None and set(by_tick) == set(run)
    for phase, seconds in by_tick.items():
        assert set(seconds) == set(range(20))
        assert sum(seconds.values()) == pytest.approx(run[phase], rel=1e-9)
    assert len(serial) > 1000
    topics = {topic for topic, _, _ in serial}
    assert {"/gcs/cycle", "/companion/decisions", "/companion/observations"} <= topics
    assert split_log == serial


def test_one_process_is_asked_for_on_the_command_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``ridsafe run --mode lockstep --one-process``: no worker is started."""

    def refuse(*_args: object) -> None:
        raise AssertionError("a worker was started")

    monkeypatch.setattr(lockstep_split.SplitLockstep, "__init__", refuse)
    argv = ["run", "--mode", "lockstep", "--one-process", "--duration", "2"]
    assert cli_main.main([*argv, "--out", str(tmp_path)]) == 0
    (end,) = [r for topic, _, r in read_records(tmp_path / "run.mcap") if topic == "/run/end"]
    assert end["status"] == "completed"
    with pytest.raises(AssertionError, match="a worker was started"):
        cli_main.main(["run", "--mode", "lockstep", "--duration", "2", "--out", str(tmp_path)])


# -- small cores, to see the order and the failures ---------------------------------------


@dataclasses.dataclass
class _Core:
    """Logs what it was handed each tick and answers each peer with its name and the tick."""

    name: str
    peers: tuple[str, ...]  # endpoint names it sends on
    sink: LogSink
    fail_at_s: float | None = None

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        if self.fail_at_s is not None and now_s >= self.fail_at_s:
            raise RuntimeError(f"{self.name} broke at {now_s:g} s")
        got = [[endpoint, data.decode()] for endpoint, data in inbound]
        self.sink.log("/test/handle", now_s, {"core": self.name, "got": got})
        return [(peer, f"{self.name}@{now_s:g}".encode()) for peer in self.peers]

    def finish(self, now_s: float) -> Datagrams:
        self.sink.log("/test/finish", now_s, {"core": self.name})
        return []


def _cores(n: int, sink: LogSink, fail: str = "") -> tuple[dict[str, _Core], list[Wire], Roles]:
    companions = [f"companion/{k}" for k in range(1, n + 1)]
    cores = {
        "sim": _Core("sim", tuple(f"to{k}" for k in range(1, n + 1)), sink),
        "gcs": _Core("gcs", tuple(f"c{k}" for k in range(1, n + 1)), sink),
    }
    wires = []
    for k, name in enumerate(companions, start=1):
        cores[name] = _Core(name, ("autopilot", "gcs"), sink)
        wires += [
            Wire(("sim", f"to{k}"), (name, "autopilot")),
            Wire(("gcs", f"c{k}"), (name, "gcs")),
        ]
    if fail:
        cores[fail].fail_at_s = 0.3
    return cores, wires, Roles("sim", "gcs", tuple(companions))


def _serial(n: int, ticks: int) -> list[tuple[str, float, Record]]:
    sink = MemorySink()
    cores, wires, roles = _cores(n, sink)
    router = ByteRouter(cores, wires, ["sim", *roles.companions, "gcs"])
    for k in range(1, ticks + 1):
        router.step(k * 0.1)
    for name in (*roles.companions, "gcs", "sim"):
        cores[name].finish(ticks * 0.1)
    return sink.records


@contextlib.contextmanager
def _split(n: int, log_path: Path, fail: str = "") -> Iterator[tuple[SplitLockstep, LogSink]]:
    """A split run of ``_cores`` writing ``log_path``, and the sink this process logs to."""
    buffer = LaneBuffer()
    cores, wires, roles = _cores(n, buffer, fail)
    router = ByteRouter(cores, wires, ["sim", *roles.companions, "gcs"])
    with SplitLockstep(router, roles, 0.1, buffer, lambda: McapRecorder(log_path)) as run:
        yield run, buffer


def _rounded(records: Iterable[tuple[str, float, Record]]) -> list[tuple[str, float, Record]]:
    """The records with their times to the microsecond and without the reader's ``t_s``."""
    rounded: list[tuple[str, float, Record]] = []
    for topic, t_s, record in records:
        fields = {key: value for key, value in record.items() if key != "t_s"}
        rounded.append((topic, round(t_s, 6), fields))
    return rounded


@pytest.mark.parametrize("early_max_bytes", [lockstep_split._EARLY_MAX_BYTES, 0])
@pytest.mark.parametrize("n", [0, 1, 2, 5])
def test_every_core_is_handed_what_the_serial_run_hands_it_in_the_same_order(
    n: int, early_max_bytes: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """... and the worker writes every record of both processes in the serial order, those
    this process logs after ``finish`` last; whether the worker's answers go before they
    are asked for (small ones) or after (all of them, with a limit of 0 bytes)."""
    monkeypatch.setattr(lockstep_split, "_EARLY_MAX_BYTES", early_max_bytes)  # the fork's too
    log_path = tmp_path / "split.mcap"
    with _split(n, log_path) as (run, sink):
        for _ in range(6):
            run.step()
        run.finish()
        sink.log("/test/end", run.t_s, {"core": "run"})
        run.close()
    written = _rounded(read_records(log_path))
    assert written == _rounded([*_serial(n, 6), ("/test/end", 0.6, {"core": "run"})])
    handed = [record["got"] for topic, _, record in written if topic == "/test/handle"]
    assert len(handed) == 6 * (n + 2) and (n == 0 or all(handed[-(n + 2) :]))


def test_records_are_merged_core_by_core_in_the_router_s_order() -> None:
    """Two processes' records of one step: each core's in the order it logged them, the cores
    in the router's order, records of no core first."""
    buffer = LaneBuffer()
    for core, topic in [("c3", "/a"), ("c1", "/b"), ("", "/meta"), ("c3", "/c"), ("c2", "/d")]:
        with buffer.lane(core):
            buffer.log(topic, 1.0, {})
    buffer.log("/after", 1.0, {})  # outside every lane again
    merged = lockstep_split.in_serial_order(buffer.take(), ["sim", "c1", "c2", "c3", "gcs"])
    assert [lane for lane, _ in merged] == ["", "", "c1", "c2", "c3", "c3"]
    assert [pickle.loads(blob)[0] for _, blob in merged] == [
        "/meta",
        "/after",
        "/b",
        "/d",
        "/a",
        "/c",
    ]


@pytest.mark.parametrize("failing", ["companion/2", "gcs"])  # the worker's
def test_a_core_failing_in_the_worker_is_an_error_and_the_log_is_finished(
    failing: str, tmp_path: Path
) -> None:
    log_path = tmp_path / "split.mcap"
    with _split(3, log_path, fail=failing) as (run, _):
        with pytest.raises(WorkerError, match=f"{failing} broke at 0.3 s"):
            for _ in range(10):
                run.step()
        assert run.t_s < 1.0
    times = [t_s for topic, t_s, _ in read_records(log_path) if topic == "/test/handle"]
    assert times.count(0.2) == 5 and max(times) == pytest.approx(0.3)  # every core at 0.2


def test_a_worker_that_dies_is_an_error_at_the_next_tick(tmp_path: Path) -> None:
    with _split(3, tmp_path / "split.mcap") as (run, _):
        run.step()
        assert run.worker_pid is not None
        os.kill(run.worker_pid, signal.SIGKILL)
        with pytest.raises(WorkerError, match="went away"):
            for _ in range(3):
                run.step()


def test_a_log_the_worker_cannot_open_is_an_error_before_the_first_tick(tmp_path: Path) -> None:
    (tmp_path / "taken").write_text("a file, not a directory")
    with pytest.raises(WorkerError, match="taken"), _split(1, tmp_path / "taken" / "run.mcap"):
        pass


def test_the_log_is_finished_when_the_run_s_process_dies(tmp_path: Path) -> None:
    """A run process killed mid-flight: its worker writes what came and closes the file."""
    log_path = tmp_path / "split.mcap"
    code = f"""
import os, signal, sys
sys.path.insert(0, {str(ROOT)!r})
from tests.tools.run.test_lockstep_split import _split
from pathlib import Path
with _split(2, Path({str(log_path)!r})) as (run, _):
    for _ in range(5):
        run.step()
    os.kill(os.getpid(), signal.SIGKILL)
"""
    done = subprocess.run([sys.executable, "-c", code], check=False, timeout=60)
    assert done.returncode == -signal.SIGKILL
    # The orphaned worker finishes the file on its own time: wait until it reads complete
    # (a file still being written reads as cut off, with what it holds so far).
    deadline = time.monotonic() + 30.0
    status = ReadStatus()
    while not status.complete and time.monotonic() < deadline:
        time.sleep(0.1)
        with contextlib.suppress(LogReadError):  # not yet created, or not yet MCAP
            status = ReadStatus()
            collections.deque(iter_messages(log_path, status), maxlen=0)
    assert status.complete, status.error
    times = [t for topic, t, _ in read_records(log_path) if topic == "/test/handle"]
    assert max(times) == 0.5 and times.count(0.5) == 4  # sim, 2 companions and the GCS


def test_a_record_that_cannot_cross_is_an_error_naming_its_topic() -> None:
    buffer = LaneBuffer()
    with pytest.raises(RecorderError, match="/test/odd: record cannot be handed"):
        buffer.log("/test/odd", 1.0, {"f": lambda: None})
    assert buffer.take() == []


def test_ctrl_c_while_the_cores_are_built_leaves_a_log_that_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupted(*_args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(lockstep, "build", interrupted)
    path = tmp_path / "run.mcap"
    result = run_lockstep(load_scenario_file(), "aware", path, split=True)
    assert result.status == "interrupted" and result.sim_time_s == 0.0
    topics = [topic for topic, _, _ in read_records(path)]
    assert topics == ["/run/meta", "/run/end"]
