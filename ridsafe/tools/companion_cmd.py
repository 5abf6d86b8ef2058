"""``ridsafe companion``: the companion computer of one or more aircraft, over MAVLink/UDP.

``ridsafe companion --vehicle 1`` flies benign aircraft 1 of the scenario: it connects to the
sim's (or a real autopilot's) companion port, waits for its heartbeat, asks for telemetry,
sets GUIDED, arms, takes off and flies to its goal, broadcasting its Remote ID through the
transponder and reporting what it hears to the GCS. ``--vehicle 1-4`` (or ``1,3``) runs
several in one process. Events and counters are printed; Ctrl-C stops.

The scenario file's ``companion:`` section (``CompanionConfig``) and ``planner:`` section
(handed to the planner factory) are optional; ``--set companion.on_arrival=land`` and
``--set companion.cruise_speed_m_s=6`` override single values.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ridsafe.common import codec, topics
from ridsafe.common.config import from_mapping, parse_override, parse_yaml, with_overrides
from ridsafe.common.errors import ConfigError, RidsafeError
from ridsafe.common.logsink import Record
from ridsafe.companion.app import (
    DEFAULT_GCS_CONNECTION,
    CompanionApp,
    Connections,
    default_autopilot_connection,
)
from ridsafe.companion.companion import Companion
from ridsafe.companion.config import CompanionConfig, CompanionSpec
from ridsafe.companion.mission import Phase
from ridsafe.companion.planners import PLANNERS, PlannerSettings, make_planner
from ridsafe.tools.scenario import ScenarioFile, resolve_config_path

__all__ = ["CompanionFile", "load_companion_file", "parse_vehicles", "register", "run"]

_SECTIONS = ("companion", "planner")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "companion",
        help="run the companion computer of one or more aircraft over MAVLink/UDP",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("config", nargs="?", help="scenario YAML (default configs/default.yaml)")
    parser.add_argument(
        "--vehicle", required=True, help="benign aircraft to fly: 2, 1-4 or 1,3 (1-based)"
    )
    parser.add_argument(
        "--autopilot", help="autopilot connection (one vehicle only; default: the sim's port)"
    )
    parser.add_argument("--gcs", default=DEFAULT_GCS_CONNECTION, help="GCS connection string")
    parser.add_argument("--signing-key", type=Path, help="MAVLink 2 signing key for the GCS link")
    parser.add_argument(
        "--planner", default="straight-line", choices=sorted(PLANNERS), help="planner name"
    )
    parser.add_argument("--speed", type=float, default=1.0, help="sim seconds per wall second")
    parser.add_argument("--duration", type=float, help="stop after this many sim seconds")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a config value, e.g. --set companion.on_arrival=land",
    )
    parser.set_defaults(func=run)


@dataclass(frozen=True)
class CompanionFile:
    """A scenario file with the companion's own sections."""

    scenario_file: ScenarioFile
    companion: CompanionConfig = field(default_factory=CompanionConfig)
    planner_options: Mapping[str, object] = field(default_factory=dict)


def load_companion_file(
    path: str | Path | None = None, overrides: Mapping[str, object] | None = None
) -> CompanionFile:
    """Read a scenario YAML: ``companion:`` and ``planner:`` here, the rest as ScenarioFile."""
    resolved = resolve_config_path(path)
    source = str(resolved)
    try:
        text = resolved.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(source, "", f"cannot read configuration file: {err}") from err
    data = parse_yaml(text, source)
    if not isinstance(data, dict):
        raise ConfigError(source, "", f"expected a mapping at the top, got {type(data).__name__}")
    sections = {name: data.pop(name, None) or {} for name in _SECTIONS}
    scenario_file = from_mapping(ScenarioFile, data, source)
    companion = from_mapping(CompanionConfig, sections["companion"], f"{source}: companion")
    planner = sections["planner"]
    if not isinstance(planner, dict):
        raise ConfigError(source, "planner", "expected a mapping")
    loaded = CompanionFile(scenario_file, companion, planner)
    return _apply_overrides(loaded, overrides or {})


def _apply_overrides(loaded: CompanionFile, overrides: Mapping[str, object]) -> CompanionFile:
    split: dict[str, dict[str, object]] = {"companion": {}, "planner": {}, "": {}}
    for key, value in overrides.items():
        head, _, rest = key.partition(".")
        bucket = head if head in _SECTIONS and rest else ""
        split[bucket][rest if bucket else key] = value
    return CompanionFile(
        with_overrides(loaded.scenario_file, split[""]) if split[""] else loaded.scenario_file,
        with_overrides(loaded.companion, split["companion"]),
        {**loaded.planner_options, **split["planner"]},
    )


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
    """Prints companion events and counters for people; drops the other records."""

    def __init__(self, stream: Any = None) -> None:
        self.stream = stream if stream is not None else sys.stdout

    def log(self, topic: str, t_s: float, record: Record) -> None:
        if topic == topics.COMPANION_EVENTS:
            line = f"[{t_s:8.2f}] v{record['sysid']} {record['event']}: {record['detail']}"
        elif topic == topics.APP_COUNTERS:
            nonzero = {k: v for k, v in record["counters"].items() if v}
            line = f"[{t_s:8.2f}] {record['app']} counters {nonzero}"
        else:
            return
        print(line, file=self.stream, flush=True)


def build_companions(
    loaded: CompanionFile,
    vehicles: Sequence[int],
    planner: str,
    sink: ConsoleSink,
    signing: codec.SigningConfig | None,
) -> list[Companion]:
    scenario, config = loaded.scenario_file.scenario, loaded.companion
    companions = []
    for sysid in vehicles:
        spec = CompanionSpec.from_scenario(scenario, sysid, config.operator_id)
        settings = PlannerSettings(
            sysid=sysid,
            cruise_speed_m_s=config.cruise_speed_m_s,
            replan_period_s=config.replan_period_s,
            lookahead_s=config.lookahead_s,
            approach_radius_m=config.approach_radius_m,
            arrival_radius_m=config.arrival_radius_m,
            seed=scenario.seed,
            options=loaded.planner_options,
        )
        companions.append(
            Companion(spec, config, make_planner(planner, settings), sink, signing=signing)
        )
    return companions


def _connections(
    args: argparse.Namespace, loaded: CompanionFile, vehicles: Sequence[int]
) -> dict[int, Connections]:
    if args.autopilot is not None and len(vehicles) != 1:
        raise ValueError("--autopilot names one autopilot: use it with a single --vehicle")
    ports = loaded.scenario_file.sim.ports
    return {
        sysid: Connections(
            args.autopilot or default_autopilot_connection(sysid, ports.companion_base, ports.host),
            args.gcs,
        )
        for sysid in vehicles
    }


def _signing(path: Path | None) -> codec.SigningConfig | None:
    if path is None:
        return None
    key = codec.load_signing_key(path)
    return codec.SigningConfig(key, codec.signing_timestamp_from_unix(time.time()))


def run(args: argparse.Namespace) -> int:
    try:
        overrides = dict(parse_override(text) for text in args.overrides)
        loaded = load_companion_file(args.config, overrides)
        vehicles = parse_vehicles(args.vehicle, len(loaded.scenario_file.scenario.aircraft))
        if args.speed <= 0:
            raise ValueError("--speed must be > 0")
        connections = _connections(args, loaded, vehicles)
        sink = ConsoleSink()
        signing = _signing(args.signing_key)
        companions = build_companions(loaded, vehicles, args.planner, sink, signing)
    except (RidsafeError, ValueError, KeyError, OSError) as exc:
        print(f"ridsafe companion: {exc}", file=sys.stderr)
        return 2
    try:
        app = CompanionApp(companions, connections, speed=args.speed)
    except (RidsafeError, OSError) as exc:
        print(f"ridsafe companion: cannot open the connections: {exc}", file=sys.stderr)
        return 1
    for sysid, conn in connections.items():
        print(f"companion {sysid}: autopilot {conn.autopilot}, gcs {conn.gcs}", flush=True)
    try:
        app.run(until_s=args.duration)
    except KeyboardInterrupt:
        print("\nstopped", file=sys.stderr)
    finally:
        app.close()
    for companion in companions:
        print(f"companion {companion.spec.sysid}: ended in {companion.phase.name}")
    return 0 if all(c.phase is not Phase.FAILED for c in companions) else 1
