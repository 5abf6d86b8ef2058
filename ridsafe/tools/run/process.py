"""What every app process shares: its clock, its start, its log, its signing key, SIGTERM.

``ridsafe sim``, ``ridsafe gcs`` and ``ridsafe companion`` each run one app alone; ``ridsafe
run --mode live`` starts them as child processes with a common start instant (``--t0-unix``)
and a part log each (``--log``). The app cores take plain objects; this is what the process
around a core needs (its arguments are parsed in ``ridsafe.tools.cli.app_args``).
"""

from __future__ import annotations

import logging
import math
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from ridsafe.common.clock import EpochClock, MonotonicClock
from ridsafe.common.codec import SigningConfig, load_signing_key, signing_timestamp_from_unix
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import LogSink, NullSink, TeeSink
from ridsafe.common.runner import RunnerClock, freeze_startup_objects

if TYPE_CHECKING:
    from ridsafe.tools.runlog.child_writer import RecorderProcess
    from ridsafe.tools.runlog.writer import McapRecorder

logger = logging.getLogger(__name__)

CGROUP_ROOT = Path("/sys/fs/cgroup")


def usable_cpus(cgroup_root: Path = CGROUP_ROOT) -> int:
    """CPUs this process may use: those in its affinity mask, and no more than its cgroup's
    CPU quota (a container's ``--cpus``; cgroup v2 ``cpu.max``, v1 ``cpu.cfs_quota_us`` over
    ``cpu.cfs_period_us``), rounded up; at least 1."""
    count = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    quota = _cgroup_cpu_quota(cgroup_root)
    if quota is not None:
        count = min(count or 1, math.ceil(quota))
    return max(count or 1, 1)


def _cgroup_cpu_quota(root: Path) -> float | None:
    """The cgroup's CPU quota in CPUs, or None (no limit, or no cgroup file to read)."""
    try:
        if (root / "cpu.max").is_file():
            quota, period = (root / "cpu.max").read_text().split()[:2]
        else:
            quota = (root / "cpu" / "cpu.cfs_quota_us").read_text().strip()
            period = (root / "cpu" / "cpu.cfs_period_us").read_text().strip()
        if quota in ("max", "-1"):
            return None
        cpus = float(quota) / float(period)
    except (OSError, ValueError):
        return None
    return cpus if cpus > 0.0 else None


def make_clock(speed: float, t0_unix: float | None) -> RunnerClock:
    """Sim time at ``speed`` from now, or from the shared start instant ``t0_unix``."""
    if t0_unix is None:
        return MonotonicClock(speed)
    return EpochClock(speed, t0_unix)


LATE_START_WARNING_S = 0.5  # wall seconds after --t0-unix


#: How often the wait for the start instant looks for a stop request (wall seconds).
START_WAIT_POLL_S = 0.1


class StopRequest:
    """A stop asked for before or while an app runs (``stop_request_on_sigterm``):
    ``set`` records it and calls every stop handed to ``forward_to``, which calls a stop at
    once if the request came before it (a SIGTERM during the start-up wait)."""

    def __init__(self) -> None:
        self._set = False
        self._stops: list[Callable[[], None]] = []

    def set(self) -> None:
        self._set = True
        for stop in self._stops:
            stop()

    def is_set(self) -> bool:
        return self._set

    def forward_to(self, stop: Callable[[], None]) -> None:
        self._stops.append(stop)
        if self._set:
            stop()


def wait_for_start(
    t0_unix: float | None, speed: float, app: str, stop: StopRequest | None = None
) -> None:
    """Called by an app once its core is built: sleep until ``t0_unix`` (processes of a
    live run start their cores together), or until ``stop`` is set; an ``app`` that is ready
    only after it says so, with how much of the run it missed.

    It also takes everything built so far (modules, numba kernels, the core) out of the
    garbage collector's reach (``freeze_startup_objects``): a full collection walked all
    ~140,000 of those objects, about 50 ms, and inside a 0.25 s GCS update that is 25 times
    its budget. The loop then only ever scans what it made itself (the collection before it
    runs in the wait)."""
    ready_unix_s = time.time()
    freeze_startup_objects()
    if t0_unix is None:
        return
    wait_s = t0_unix - ready_unix_s
    if wait_s >= 0.0:
        while stop is None or not stop.is_set():
            left_s = t0_unix - time.time()
            if left_s <= 0.0:
                break
            time.sleep(min(left_s, START_WAIT_POLL_S))
    elif -wait_s > LATE_START_WARNING_S:
        logger.warning(
            "%s: ready %.1f s (wall) after the run's start instant; the first %.1f s of sim "
            "time ran without it",
            app,
            -wait_s,
            -wait_s * speed,
        )


def open_run_log(
    path: Path, origin: GeodeticOrigin | None, foxglove: bool, child_process: bool = False
) -> McapRecorder | RecorderProcess:
    """The run log writer for ``path``: with the derived Foxglove channels or without, in this
    process or (``child_process``) in a child on another core."""
    # mcap only when logging
    from ridsafe.tools.runlog.child_writer import RecorderProcess  # noqa: PLC0415
    from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels  # noqa: PLC0415
    from ridsafe.tools.runlog.writer import McapRecorder  # noqa: PLC0415

    path.parent.mkdir(parents=True, exist_ok=True)
    plugins = (FoxgloveChannels(origin),) if foxglove else ()
    if child_process:
        return RecorderProcess(path, plugins=plugins)
    return McapRecorder(path, plugins=plugins)


def open_sink(path: Path | None, origin: GeodeticOrigin, foxglove: bool = True) -> LogSink:
    """An app process's log: the run log writer for ``path`` (:func:`open_run_log`), or a
    sink that drops everything."""
    if path is None:
        return NullSink()
    return open_run_log(path, origin, foxglove)


def with_live_view(sink: LogSink, address: str, origin: GeodeticOrigin) -> LogSink:
    """``sink`` and a live Foxglove view on ``address`` ([HOST:]PORT) for every record; the
    result's ``close`` closes both (:func:`close_sink`)."""
    from ridsafe.tools.runlog.foxglove_live import (  # noqa: PLC0415 (an optional extra)
        FoxgloveLiveServer,
        parse_host_port,
    )

    host, port = parse_host_port(address)
    server = FoxgloveLiveServer(host, port, origin)
    logger.info("serving the run live to Foxglove at %s", server.url)
    return TeeSink((sink, server))


def close_sink(sink: LogSink) -> None:
    """Close ``sink`` (and every sink of a ``TeeSink``) if it can be closed."""
    for each in sink.sinks if isinstance(sink, TeeSink) else (sink,):
        close = getattr(each, "close", None)
        if callable(close):
            close()


def signing_from_file(path: Path | None) -> SigningConfig | None:
    """Signing with the key in ``path``; outgoing timestamps start at the wall clock so a
    restarted process is not taken for a replay."""
    if path is None:
        return None
    return SigningConfig(load_signing_key(path), signing_timestamp_from_unix(time.time()))


def stop_on_sigterm(stop: Callable[[], None]) -> Callable[[], None]:
    """SIGTERM (a supervisor ending the run) calls ``stop`` so the app can close its log;
    returns what restores the previous handler."""

    def handler(_signum: int, _frame: FrameType | None) -> None:
        stop()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        return lambda: None

    def restore() -> None:
        signal.signal(signal.SIGTERM, previous)

    return restore


def stop_request_on_sigterm() -> tuple[StopRequest, Callable[[], None]]:
    """A ``StopRequest`` that SIGTERM sets, from now on (before the app announces itself, so
    a supervisor's SIGTERM at any later point lets it close its log), and what restores the
    previous handler."""
    stop = StopRequest()
    return stop, stop_on_sigterm(stop.set)
