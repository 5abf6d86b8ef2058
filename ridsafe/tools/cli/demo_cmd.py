"""``ridsafe demo``: one sim vehicle flown over MAVLink/UDP, start to landing, track printed.

The sim backend runs in a background thread behind its real UDP ports (as ``ridsafe sim``
would); the foreground plays a ground station on ``udpin:127.0.0.1:14550``: wait for the
heartbeat, GUIDED, arm, take off to 30 m, fly to a position target, LAND, wait for the
automatic disarm (:mod:`ridsafe.tools.run.demo`). Ends by itself.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import threading

from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError
from ridsafe.common.logsink import NullSink
from ridsafe.common.udp import UdpEndpoint
from ridsafe.sim_backend.app import make_runner
from ridsafe.sim_backend.world import EndpointKind
from ridsafe.tools.cli.arg_types import positive_float
from ridsafe.tools.run import cores
from ridsafe.tools.run.demo import GroundStation
from ridsafe.tools.run.scenario import load_scenario_file, rescale_aircraft

TAKEOFF_ALT_M = 30.0
TARGET_NED_M = (120.0, 80.0, -TAKEOFF_ALT_M)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="fly one sim vehicle over MAVLink/UDP: arm, take off, fly, land",
        description=__doc__,
    )
    parser.add_argument("config", nargs="?", help="scenario YAML (default configs/default.yaml)")
    parser.add_argument(
        "--speed", type=positive_float, default=4.0, help="sim seconds per wall second"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        loaded = load_scenario_file(args.config)
    except (RidsafeError, OSError) as exc:
        print(f"ridsafe demo: {exc}", file=sys.stderr)
        return 2
    scenario = dataclasses.replace(
        rescale_aircraft(loaded.scenario, 1), spoofer=None, spoofers=(), ghosts=()
    )
    loaded = dataclasses.replace(loaded, scenario=scenario)
    ports = loaded.sim.ports
    backend = cores.make_sim_backend(loaded, NullSink(), [EndpointKind.GCS])
    station = GroundStation(UdpEndpoint(ports.host, ports.gcs_out_port(1)), sysid=1)
    runner = make_runner(backend, ports, speed=args.speed)
    thread = threading.Thread(target=runner.run, name="sim", daemon=True)
    thread.start()
    try:
        fly(station, args.speed)
    except (TimeoutError, RidsafeError) as exc:
        print(f"ridsafe demo: {exc}", file=sys.stderr)
        return 1
    finally:
        runner.stop()
        thread.join(timeout=5.0)
        runner.close()
        station.endpoint.close()
    return 0


def fly(station: GroundStation, speed: float) -> None:
    print(f"waiting for vehicle {station.sysid} on udpin:127.0.0.1:14550 ...", flush=True)
    station.wait_for("HEARTBEAT", lambda: station.heartbeat() is not None)
    _check("GUIDED", station.command(m.MavCmd.DO_SET_MODE, 1, m.CopterMode.GUIDED))
    _check("arm", station.command(m.MavCmd.COMPONENT_ARM_DISARM, 1))
    _check("takeoff", station.command(m.MavCmd.NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, TAKEOFF_ALT_M))
    print(f"{'t (s)':>7} {'north':>8} {'east':>8} {'alt':>7} {'speed':>6}  mode      phase")
    track = _Track(station)
    station.timeout_wall_s = 120.0 / speed
    station.wait_for("takeoff", lambda: track.show("takeoff") and track.alt_m() > 29.0)
    target = m.SetPositionTargetLocalNed(
        0.0, station.sysid, 1, m.MavFrame.LOCAL_NED, m.PositionTargetMask.POSITION_ONLY,
        TARGET_NED_M, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0,
    )  # fmt: skip
    station.send(target)
    station.wait_for(
        "target", lambda: track.show("cruise") and track.distance_to(TARGET_NED_M) < 1.0
    )
    _check("LAND", station.command(m.MavCmd.NAV_LAND))
    station.wait_for("disarm", lambda: track.show("land") and not _armed(station))
    track.show("landed", force=True)
    print("landed and disarmed; autopilot said: " + " | ".join(station.texts))


def _check(what: str, result: int) -> None:
    if result != m.MavResult.ACCEPTED:
        raise RidsafeError(f"{what} rejected: {m.MavResult(result).name}")
    print(f"{what}: accepted", flush=True)


def _armed(station: GroundStation) -> bool:
    heartbeat = station.heartbeat()
    return heartbeat is not None and heartbeat.armed


class _Track:
    """Prints the vehicle's local position about once per sim second."""

    def __init__(self, station: GroundStation) -> None:
        self.station = station
        self.next_s = 0.0

    def alt_m(self) -> float:
        pos = self.station.local_position()
        return -pos.p_ned_m[2] if pos is not None else 0.0

    def distance_to(self, p_ned_m: tuple[float, float, float]) -> float:
        pos = self.station.local_position()
        return math.inf if pos is None else math.dist(pos.p_ned_m, p_ned_m)

    def show(self, phase: str, force: bool = False) -> bool:
        pos = self.station.local_position()
        heartbeat = self.station.heartbeat()
        if pos is None or heartbeat is None or (pos.time_boot_s < self.next_s and not force):
            return True
        self.next_s = pos.time_boot_s + 1.0
        n, e, d = pos.p_ned_m
        speed = math.hypot(*pos.v_ned_m_s)
        mode = m.CopterMode(heartbeat.custom_mode).name
        print(
            f"{pos.time_boot_s:7.1f} {n:8.1f} {e:8.1f} {-d:7.1f} {speed:6.2f}  {mode:<8}  {phase}"
        )
        return True
