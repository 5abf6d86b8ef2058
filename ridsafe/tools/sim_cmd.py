"""``ridsafe sim``: the sim backend alone, over UDP, like ArduPilot SITL instances."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys

from ridsafe.common.config import parse_override
from ridsafe.common.errors import RidsafeError
from ridsafe.sim_backend.app import describe_ports, make_runner
from ridsafe.sim_backend.world import EndpointKind, SimBackend
from ridsafe.tools.scenario import ScenarioFile, load_scenario_file, rescale_aircraft

logger = logging.getLogger(__name__)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "sim",
        help="run the octorotor sim backend alone over MAVLink/UDP",
        description="Run the sim backend: vehicle i streams MAVLink to 127.0.0.1:14550+10(i-1) "
        "and listens for its companion on 127.0.0.1:5760+10(i-1).",
    )
    add_scenario_arguments(parser)
    parser.add_argument(
        "--vehicles", type=int, help="number of benign vehicles (rescales the scenario)"
    )
    parser.add_argument("--speed", type=float, default=1.0, help="sim seconds per wall second")
    parser.add_argument("--duration", type=float, help="stop after this many sim seconds")
    parser.add_argument("--no-spoofer", action="store_true", help="leave the spoofer out")
    parser.set_defaults(func=run)


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


def load_from_args(args: argparse.Namespace) -> ScenarioFile:
    overrides = dict(parse_override(text) for text in args.overrides)
    loaded = load_scenario_file(args.config, overrides)
    scenario = loaded.scenario
    if getattr(args, "vehicles", None) is not None:
        scenario = rescale_aircraft(scenario, args.vehicles)
    if getattr(args, "no_spoofer", False):
        scenario = dataclasses.replace(scenario, spoofer=None)
    return dataclasses.replace(loaded, scenario=scenario)


def run(args: argparse.Namespace) -> int:
    try:
        loaded = load_from_args(args)
    except (RidsafeError, ValueError, OSError) as exc:
        print(f"ridsafe sim: {exc}", file=sys.stderr)
        return 2
    if args.speed <= 0:
        print("ridsafe sim: --speed must be > 0", file=sys.stderr)
        return 2
    kinds = [EndpointKind.COMPANION]
    if loaded.sim.ports.gcs_out_enabled:
        kinds.append(EndpointKind.GCS)
    backend = SimBackend(loaded.scenario, loaded.sim, kinds)
    try:
        runner = make_runner(backend, loaded.sim.ports, speed=args.speed)
    except OSError as exc:
        print(f"ridsafe sim: cannot open the ports: {exc}", file=sys.stderr)
        return 1
    for line in describe_ports(backend, loaded.sim.ports):
        print(line)
    print(f"running at {args.speed:g}x real time; Ctrl-C stops", flush=True)
    progress = _Progress(backend)
    try:
        runner.run(until_s=args.duration, on_tick=progress)
    except KeyboardInterrupt:
        print("\nstopped", file=sys.stderr)
    finally:
        runner.close()
    print(f"done at t = {backend.t_s:.1f} s; {runner.stats}")
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
