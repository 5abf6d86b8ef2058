"""What every app command shares: scenario arguments, process arguments, clock, log, signing.

``ridsafe sim``, ``ridsafe gcs`` and ``ridsafe companion`` each run one app alone; ``ridsafe
run --mode live`` starts them as child processes with a common start instant (``--t0-unix``)
and a part log each (``--log``). Everything here is for the command line; the app cores
take plain objects.
"""

from __future__ import annotations

import argparse
import gc
import logging
import signal
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType

from ridsafe.common.clock import EpochClock, MonotonicClock
from ridsafe.common.codec import SigningConfig, load_signing_key, signing_timestamp_from_unix
from ridsafe.common.config import parse_override
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import LogSink, NullSink
from ridsafe.common.runner import RunnerClock
from ridsafe.tools.scenario import ScenarioFile, load_scenario_file

logger = logging.getLogger(__name__)


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", nargs="?", help="scenario YAML (default configs/default.yaml)")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a config value, e.g. --set sim.controller.max_tilt_deg=25",
    )


def load_scenario_args(args: argparse.Namespace) -> ScenarioFile:
    overrides = dict(parse_override(text) for text in args.overrides)
    return load_scenario_file(args.config, overrides)


def add_process_arguments(parser: argparse.ArgumentParser) -> None:
    """--speed, --duration, --t0-unix, --log: how one app process runs in time."""
    parser.add_argument("--speed", type=float, default=1.0, help="sim seconds per wall second")
    parser.add_argument("--duration", type=float, help="stop at this sim time (s)")
    parser.add_argument(
        "--t0-unix",
        type=float,
        metavar="SECONDS",
        help="UNIX time at which sim time is 0, shared by every process of a live run",
    )
    parser.add_argument("--log", type=Path, metavar="PATH", help="write a run log (MCAP)")


def check_speed(args: argparse.Namespace) -> None:
    if not args.speed > 0:
        raise ValueError(f"--speed must be > 0, got {args.speed}")


def make_clock(args: argparse.Namespace) -> RunnerClock:
    """Sim time from now, or from the shared start instant ``--t0-unix``."""
    if args.t0_unix is None:
        return MonotonicClock(args.speed)
    return EpochClock(args.speed, args.t0_unix)


LATE_START_WARNING_S = 0.5  # wall seconds after --t0-unix


def wait_for_start(args: argparse.Namespace, app: str) -> None:
    """Called by an app once its core is built: sleep until ``--t0-unix`` (processes of a
    live run start their cores together); an ``app`` that is ready only after it says so,
    with how much of the run it missed.

    It also takes everything built so far (modules, numba kernels, the core) out of the
    garbage collector's reach (``gc.freeze``): a full collection walked all ~140,000 of those
    objects, about 50 ms, and inside a 0.25 s GCS update that is 25 times its budget. The loop
    then only ever scans what it made itself (the collection before it runs in the wait)."""
    ready_unix_s = time.time()
    gc.collect()
    gc.freeze()
    if args.t0_unix is None:
        return
    wait_s = args.t0_unix - ready_unix_s
    if wait_s >= 0.0:
        time.sleep(max(0.0, args.t0_unix - time.time()))
    elif -wait_s > LATE_START_WARNING_S:
        logger.warning(
            "%s: ready %.1f s (wall) after the run's start instant; the first %.1f s of sim "
            "time ran without it",
            app,
            -wait_s,
            -wait_s * args.speed,
        )


def open_sink(path: Path | None, origin: GeodeticOrigin, foxglove: bool = True) -> LogSink:
    """The MCAP recorder writing ``path`` (with the derived Foxglove channels or without), or
    a sink that drops everything."""
    if path is None:
        return NullSink()
    from ridsafe.tools.recorder import McapRecorder  # noqa: PLC0415 (mcap only when logging)

    path.parent.mkdir(parents=True, exist_ok=True)
    return McapRecorder(path, origin=origin, foxglove=foxglove)


def close_sink(sink: LogSink) -> None:
    close = getattr(sink, "close", None)
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
