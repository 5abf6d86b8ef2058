"""``ridsafe sim``: the sim backend alone, over UDP, like ArduPilot SITL instances."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

from ridsafe.common.codec import SigningConfig
from ridsafe.common.errors import RidsafeError
from ridsafe.common.logsink import LogSink
from ridsafe.common.runner import UdpRunner
from ridsafe.sim_backend.app import describe_ports, open_endpoints
from ridsafe.sim_backend.world import SimBackend
from ridsafe.tools.cli import app_args
from ridsafe.tools.cli.arg_types import positive_int
from ridsafe.tools.run import cores, process
from ridsafe.tools.run.scenario import ScenarioFile, with_aircraft

logger = logging.getLogger(__name__)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "sim",
        help="run the octorotor sim backend alone over MAVLink/UDP",
        description="Run the sim backend: vehicle i streams MAVLink to 127.0.0.1:14550+10(i-1) "
        "and listens for its companion on 127.0.0.1:5760+10(i-1).",
    )
    app_args.add_scenario_arguments(parser)
    app_args.add_process_arguments(parser)
    parser.add_argument(
        "--vehicles", type=positive_int, help="number of benign vehicles (rescales the scenario)"
    )
    parser.add_argument("--no-spoofer", action="store_true", help="leave the spoofer out")
    parser.add_argument(
        "--autopilot-signing-key",
        type=Path,
        help="MAVLink 2 signing key of the companion ports (only signed frames are taken)",
    )
    parser.add_argument(
        "--foxglove", metavar="[HOST:]PORT", help="serve the channels live to the Foxglove app"
    )
    parser.set_defaults(func=run)


def load_from_args(args: argparse.Namespace) -> ScenarioFile:
    loaded = app_args.load_scenario_args(args)
    if args.vehicles is not None:
        loaded = with_aircraft(loaded, args.vehicles, app_args.override_pairs(args))
    if args.no_spoofer:
        loaded = dataclasses.replace(
            loaded,
            scenario=dataclasses.replace(loaded.scenario, spoofer=None, spoofers=(), ghosts=()),
        )
    return loaded


def build_backend(
    loaded: ScenarioFile, sink: LogSink, autopilot_signing: SigningConfig | None = None
) -> SimBackend:
    """The sim of a live run (the factory's, with the live endpoints)."""
    endpoints = cores.live_sim_endpoints(loaded)
    return cores.make_sim_backend(loaded, sink, endpoints, autopilot_signing)


def run(args: argparse.Namespace) -> int:
    try:
        app_args.check_speed(args)
        loaded = load_from_args(args)
        autopilot_signing = process.signing_from_file(args.autopilot_signing_key)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe sim: {exc}", file=sys.stderr)
        return 2
    sink = process.open_sink(args.log, loaded.scenario.origin, loaded.run.foxglove_channels)
    if args.foxglove:
        try:
            sink = process.with_live_view(sink, args.foxglove, loaded.scenario.origin)
        except RidsafeError as exc:
            process.close_sink(sink)
            print(f"ridsafe sim: {exc}", file=sys.stderr)
            return 2
    backend = build_backend(loaded, sink, autopilot_signing)
    try:
        endpoints = open_endpoints(backend, loaded.sim.ports)
    except OSError as exc:
        process.close_sink(sink)
        print(f"ridsafe sim: cannot open the ports: {exc}", file=sys.stderr)
        return 1
    stop, restore = process.stop_request_on_sigterm()
    runner: UdpRunner | None = None
    try:
        for line in describe_ports(backend, loaded.sim.ports):
            print(line)
        print(f"running at {args.speed:g}x real time; Ctrl-C stops", flush=True)
        app_args.wait_for_start(args, "sim", stop)
        runner = UdpRunner(backend, endpoints, app_args.make_clock(args), loaded.run.live_tick_s)
        stop.forward_to(runner.stop)
        runner.run(until_s=args.duration, on_tick=_Progress(backend))
    except KeyboardInterrupt:
        print("\nstopped", file=sys.stderr)
    finally:
        restore()
        if runner is not None:
            runner.close()
        else:  # stopped before the start instant
            for endpoint in endpoints.values():
                endpoint.close()
        backend.finish(backend.t_s)
        process.close_sink(sink)
    if runner is None:
        print("stopped before the start")
        return 0
    refused = sum(lock.foreign for lock in runner.locks.values())
    print(f"done at t = {backend.t_s:.1f} s; {runner.stats}; not from the peer: {refused}")
    return 0


class _Progress:
    """Prints a status line every 5 sim seconds."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend
        self.next_s = 5.0

    def __call__(self, now_s: float) -> None:
        if now_s < self.next_s:
            return
        self.next_s += 5.0
        truth = self.backend.truth()
        airborne = int((truth.p_enu_m[:, 2] > 0.5).sum())
        print(
            f"t={now_s:7.1f} s  armed {int(truth.armed.sum())}/{len(truth.armed)}  "
            f"airborne {airborne}",
            flush=True,
        )
