"""Arguments every app command shares: the scenario file with overrides, and how the process
runs in time (``--speed``, ``--duration``, ``--t0-unix``, ``--log``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ridsafe.common.config import parse_override
from ridsafe.common.runner import RunnerClock
from ridsafe.tools.cli.arg_types import finite_float, positive_float
from ridsafe.tools.run import process
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file

__all__ = [
    "add_process_arguments",
    "add_scenario_arguments",
    "check_speed",
    "load_scenario_args",
    "make_clock",
    "wait_for_start",
]


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
    return load_scenario_file(args.config, override_pairs(args))


def override_pairs(args: argparse.Namespace) -> dict[str, object]:
    """The ``--set`` overrides as {dotted key: value}."""
    return dict(parse_override(text) for text in args.overrides)


def add_process_arguments(parser: argparse.ArgumentParser) -> None:
    """--speed, --duration, --t0-unix, --log: how one app process runs in time."""
    parser.add_argument(
        "--speed", type=positive_float, default=1.0, help="sim seconds per wall second"
    )
    parser.add_argument("--duration", type=positive_float, help="stop at this sim time (s)")
    parser.add_argument(
        "--t0-unix",
        type=finite_float,
        metavar="SECONDS",
        help="UNIX time at which sim time is 0, shared by every process of a live run",
    )
    parser.add_argument("--log", type=Path, metavar="PATH", help="write a run log (MCAP)")


def check_speed(args: argparse.Namespace) -> None:
    if not args.speed > 0:
        raise ValueError(f"--speed must be > 0, got {args.speed}")


def make_clock(args: argparse.Namespace) -> RunnerClock:
    """The process's sim clock from ``--speed`` and ``--t0-unix``."""
    return process.make_clock(args.speed, args.t0_unix)


def wait_for_start(
    args: argparse.Namespace, app: str, stop: process.StopRequest | None = None
) -> None:
    """:func:`ridsafe.tools.run.process.wait_for_start` at ``--t0-unix`` and ``--speed``
    (the objects built so far frozen out of the garbage collector's reach first), cut short
    by ``stop``."""
    process.wait_for_start(args.t0_unix, args.speed, app, stop)
