"""``ridsafe companion``: the companion computer of one or more aircraft, over MAVLink/UDP.

``ridsafe companion --vehicle 1`` flies benign aircraft 1 of the scenario: it connects to the
sim's (or a real autopilot's) companion port, waits for its heartbeat, asks for telemetry,
sets GUIDED, arms, takes off and flies to its goal, broadcasting its Remote ID through the
transponder and reporting what it hears to the GCS. ``--vehicle 1-4`` (or ``1,3``) runs
several in one process. Events and counters are printed; Ctrl-C stops.

The scenario file's ``companion:`` (``CompanionConfig``) and ``planner:`` (``PlannerConfig``)
sections are optional; ``--set companion.on_arrival=land`` and
``--set companion.cruise_speed_m_s=6`` override single values.

``--rid-source capture:FILE`` feeds the companion the Remote ID of a capture of real
receivers (Wi-Fi pcap/pcapng with radiotap, Bluetooth btsnoop) instead of the transponder's,
replayed relative to the capture's first record (docs/receivers.md).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ridsafe.common import codec, topics
from ridsafe.common.errors import RidsafeError
from ridsafe.common.logsink import LogSink, Record
from ridsafe.companion.app import (
    DEFAULT_GCS_CONNECTION,
    CompanionApp,
    Connections,
    default_autopilot_connection,
)
from ridsafe.companion.companion import Companion
from ridsafe.companion.mission import Phase
from ridsafe.companion.planners import PLANNERS
from ridsafe.tools.cli import app_args, rid_source
from ridsafe.tools.cli.arg_types import connection_string, finite_float
from ridsafe.tools.run import cores, process
from ridsafe.tools.run.scenario import ScenarioFile

__all__ = ["build_companions", "parse_vehicles", "register", "run"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "companion",
        help="run the companion computer of one or more aircraft over MAVLink/UDP",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    app_args.add_scenario_arguments(parser)
    app_args.add_process_arguments(parser)
    parser.add_argument(
        "--vehicle", required=True, help="benign aircraft to fly: 2, 1-4 or 1,3 (1-based)"
    )
    parser.add_argument(
        "--autopilot",
        type=connection_string,
        help="autopilot connection (one vehicle only; default: the sim's port)",
    )
    parser.add_argument(
        "--gcs",
        type=connection_string,
        default=DEFAULT_GCS_CONNECTION,
        help="GCS connection string",
    )
    parser.add_argument("--signing-key", type=Path, help="MAVLink 2 signing key for the GCS link")
    parser.add_argument(
        "--autopilot-signing-key", type=Path, help="MAVLink 2 signing key for the autopilot link"
    )
    parser.add_argument(
        "--planner", choices=sorted(PLANNERS), help="planner name (default: run.planner)"
    )
    parser.add_argument(
        "--rid-source",
        default=rid_source.TRANSPONDER,
        help="heard RID frames: 'transponder' (default) or capture:FILE "
        "(also pcap:/pcapng:/btsnoop:FILE); one --vehicle only for a capture",
    )
    parser.add_argument(
        "--rid-start-s",
        type=finite_float,
        default=0.0,
        help="companion time (s) at which the capture's first record is heard (default 0)",
    )
    parser.add_argument(
        "--keep-running",
        action="store_true",
        help="stay up after every mission is DONE or FAILED (default: exit then)",
    )
    parser.set_defaults(func=run)


def parse_vehicles(text: str, count: int) -> list[int]:
    """``"2"``, ``"1-4"``, ``"1,3"`` -> sorted system ids, each within 1..count."""
    ids: set[int] = set()
    try:
        for part in text.split(","):
            low, sep, high = part.strip().partition("-")
            first, last = int(low), int(high) if sep else int(low)
            if first > last:
                raise ValueError(f"empty range {part!r}")
            ids.update(range(first, last + 1))
    except ValueError as exc:
        raise ValueError(f"--vehicle {text!r}: expected e.g. 2, 1-4 or 1,3 ({exc})") from None
    outside = sorted(i for i in ids if not 1 <= i <= count)
    if outside:
        raise ValueError(f"--vehicle {text!r}: no benign aircraft {outside} (have 1..{count})")
    return sorted(ids)


class ConsoleSink:
    """Prints companion events and counters for people and passes every record on."""

    def __init__(self, inner: LogSink, stream: Any = None) -> None:
        self.inner = inner
        self.stream = stream if stream is not None else sys.stdout

    def log(self, topic: str, t_s: float, record: Record) -> None:
        self.inner.log(topic, t_s, record)
        if topic == topics.COMPANION_EVENTS:
            line = f"[{t_s:8.2f}] v{record['sysid']} {record['event']}: {record['detail']}"
        elif topic == topics.APP_COUNTERS:
            nonzero = {k: v for k, v in record["counters"].items() if v}
            line = f"[{t_s:8.2f}] {record['app']} counters {nonzero}"
        else:
            return
        print(line, file=self.stream, flush=True)


def build_companions(
    args: argparse.Namespace,
    loaded: ScenarioFile,
    vehicles: Sequence[int],
    sink: LogSink,
    signing: codec.SigningConfig | None,
    autopilot_signing: codec.SigningConfig | None = None,
) -> list[Companion]:
    """The companions of ``vehicles`` with the planner the arguments name (default
    ``run.planner``), built by the factory (``run.cores.make_companions``)."""
    planner = args.planner or loaded.run.planner
    built = cores.make_companions(loaded, vehicles, planner, sink, signing, autopilot_signing)
    return list(built.values())


def _connections(
    args: argparse.Namespace, loaded: ScenarioFile, vehicles: Sequence[int]
) -> dict[int, Connections]:
    if args.autopilot is not None and len(vehicles) != 1:
        raise ValueError("--autopilot names one autopilot: use it with a single --vehicle")
    ports = loaded.sim.ports
    return {
        sysid: Connections(
            args.autopilot or default_autopilot_connection(sysid, ports.companion_base, ports.host),
            args.gcs,
        )
        for sysid in vehicles
    }


class _StopWhenDone:
    """Stops the app once every companion's mission has ended (DONE or FAILED)."""

    def __init__(self, app: CompanionApp) -> None:
        self.app = app

    def __call__(self, _now_s: float) -> None:
        companions = self.app.fleet.companions.values()
        if all(c.phase in (Phase.DONE, Phase.FAILED) for c in companions):
            self.app.stop()


def run(args: argparse.Namespace) -> int:
    try:
        app_args.check_speed(args)
        loaded = app_args.load_scenario_args(args)
        vehicles = parse_vehicles(args.vehicle, len(loaded.scenario.aircraft))
        connections = _connections(args, loaded, vehicles)
        signing = process.signing_from_file(args.signing_key)
        autopilot_signing = process.signing_from_file(args.autopilot_signing_key)
        source = rid_source.parse_rid_source(args.rid_source)
        if source.path is not None and len(vehicles) != 1:
            raise ValueError("--rid-source with a capture is one receiver: use a single --vehicle")
    except (RidsafeError, ValueError, KeyError, OSError) as exc:
        print(f"ridsafe companion: {exc}", file=sys.stderr)
        return 2
    sink = ConsoleSink(
        process.open_sink(args.log, loaded.scenario.origin, loaded.run.foxglove_channels)
    )
    try:
        companions = build_companions(args, loaded, vehicles, sink, signing, autopilot_signing)
        for companion in companions:
            companion.receiver = rid_source.make_receiver(
                source, args.rid_start_s, companion.spec.serial
            )
        app = CompanionApp(
            companions,
            connections,
            tick_s=loaded.run.live_tick_s,
            clock=app_args.make_clock(args),
        )
    except (RidsafeError, ValueError, KeyError, OSError) as exc:
        process.close_sink(sink.inner)
        print(f"ridsafe companion: {exc}", file=sys.stderr)
        return 1
    stop, restore = process.stop_request_on_sigterm()
    stop.forward_to(app.stop)
    try:
        for sysid, conn in connections.items():
            print(f"companion {sysid}: autopilot {conn.autopilot}, gcs {conn.gcs}", flush=True)
        app_args.wait_for_start(args, f"companion {args.vehicle}", stop)
        on_tick = None if args.keep_running else _StopWhenDone(app)
        app.run(until_s=args.duration, on_tick=on_tick)
    except KeyboardInterrupt:
        print("\nstopped", file=sys.stderr)
    finally:
        restore()
        app.close()
        process.close_sink(sink.inner)
    for companion in companions:
        print(f"companion {companion.spec.sysid}: ended in {companion.phase.name}")
    return 0 if all(c.phase is not Phase.FAILED for c in companions) else 1
