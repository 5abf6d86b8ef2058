"""``ridsafe gcs``: the ground station alone, over UDP, on one port every companion talks to."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ridsafe.common.errors import ConnectionStringError, RidsafeError
from ridsafe.common.runner import UdpRunner
from ridsafe.gcs.app import DEFAULT_LISTEN, listen_spec, make_runner
from ridsafe.gcs.config import ClockSource
from ridsafe.gcs.gcs import Gcs
from ridsafe.tools.cli import app_args
from ridsafe.tools.run import cores, process

PROGRESS_EVERY_S = 5.0


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "gcs",
        help="run the ground station (spoofing detection, tracking, unsafe regions) over UDP",
        description="Run the GCS: companions send observation reports to the --listen port; "
        "every live companion gets spoofing alerts and unsafe regions back.",
    )
    app_args.add_scenario_arguments(parser)
    app_args.add_process_arguments(parser)
    parser.add_argument(
        "--listen",
        type=_listen_text,
        default=DEFAULT_LISTEN,
        help=f"udpin:HOST:PORT (default {DEFAULT_LISTEN})",
    )
    parser.add_argument(
        "--signing-key",
        type=Path,
        metavar="FILE",
        help="MAVLink 2 signing key file (64 hex digits or a passphrase); unsigned and "
        "wrongly signed packets are then rejected",
    )
    parser.add_argument(
        "--clock",
        choices=[c.value for c in ClockSource],
        help="where sim time comes from: 'local' (this process's start, or --t0-unix; the "
        "default with --t0-unix) or 'peers' (the companions' reports; the default without: "
        "the GCS may start before or after them)",
    )
    parser.set_defaults(func=run)


def _listen_text(text: str) -> str:
    """--listen checked where it is parsed, so its error names the flag."""
    try:
        listen_spec(text)
    except ConnectionStringError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def clock_source(args: argparse.Namespace) -> ClockSource:
    if args.clock is not None:
        return ClockSource(args.clock)
    return ClockSource.PEERS if args.t0_unix is None else ClockSource.LOCAL


def build_gcs(args: argparse.Namespace) -> Gcs:
    """The GCS the arguments ask for, built by the factory (``run.cores.make_gcs``)."""
    loaded = app_args.load_scenario_args(args)
    signing = process.signing_from_file(args.signing_key)
    listen_spec(args.listen)
    app_args.check_speed(args)
    sink = process.open_sink(args.log, loaded.scenario.origin, loaded.run.foxglove_channels)
    return cores.make_gcs(loaded, sink, signing, clock=clock_source(args))


def run(args: argparse.Namespace) -> int:
    try:
        gcs = build_gcs(args)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe gcs: {exc}", file=sys.stderr)
        return 2
    try:
        runner = make_runner(gcs, args.listen, speed=args.speed, t0_unix=args.t0_unix)
    except (RidsafeError, OSError) as exc:
        process.close_sink(gcs.sink)
        print(f"ridsafe gcs: cannot open {args.listen}: {exc}", file=sys.stderr)
        return 1
    stop, restore = process.stop_request_on_sigterm()
    stop.forward_to(runner.stop)
    try:
        host, port = runner.endpoints["companions"].local_address
        signed = "signed" if gcs.signing is not None else "unsigned"
        print(f"GCS listening on udpin:{host}:{port} ({signed}); companions send there")
        print(f"sim time: {_describe_clock(gcs, args.t0_unix)}")
        print(f"running at {args.speed:g}x real time; Ctrl-C stops", flush=True)
        app_args.wait_for_start(args, "gcs", stop)
        runner.run(until_s=args.duration, on_tick=_Progress(gcs, runner))
    except KeyboardInterrupt:
        print("\nstopped", file=sys.stderr)
    finally:
        restore()
        gcs.finish(max(0.0, runner.clock.now_s()))  # stopped before t0: log at 0
        runner.close()
        process.close_sink(gcs.sink)
    counters = gcs.counter_values()
    summary = ", ".join(f"{k} {v}" for k, v in counters.items() if v)
    print(f"done at t = {runner.clock.now_s():.1f} s; {summary}")
    return 0


def _describe_clock(gcs: Gcs, t0_unix: float | None) -> str:
    if gcs.config.clock is ClockSource.PEERS:
        return "learned from the companions' first report"
    return "0 now" if t0_unix is None else f"0 at UNIX time {t0_unix:.3f}"


class _Progress:
    """Prints a status line every few seconds of runner time."""

    def __init__(self, gcs: Gcs, runner: UdpRunner) -> None:
        self.gcs = gcs
        self.runner = runner
        self.next_s = PROGRESS_EVERY_S

    def __call__(self, now_s: float) -> None:
        if now_s < self.next_s:
            return
        self.next_s += PROGRESS_EVERY_S
        c = self.gcs.counter_values()
        sim = self.gcs.sim_time_s(now_s)
        sim_text = "waiting for reports" if sim is None else f"sim t={sim:7.1f} s"
        print(
            f"{sim_text}  peers {c['peers_live']}/{c['peers_known']}  "
            f"reports {c['observations_accepted']}  transmissions {c['transmissions_closed']}  "
            f"cycles {c['cycles']}  regions sent {c['regions_sent']}",
            flush=True,
        )
