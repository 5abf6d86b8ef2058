#!/usr/bin/env python3
"""Fly one ridsafe sim vehicle in GUIDED with plain pymavlink, as any ground station would.

Start the sim first (``ridsafe sim``), then:

    python examples/fly_guided.py --vehicle 2

Vehicle i streams to udpin:127.0.0.1:(14550 + 10 (i - 1)), exactly like ArduPilot SITL
instance i - 1, so this script works unchanged against ArduCopter SITL.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil


def wait_ack(master: mavutil.mavfile, command: int, timeout_s: float = 10.0) -> int:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ack = master.recv_match(type="COMMAND_ACK", blocking=True, timeout=1.0)
        if ack is not None and ack.command == command:
            return int(ack.result)
    raise TimeoutError(f"no COMMAND_ACK for command {command}")


def local_position(master: mavutil.mavfile) -> mavutil.mavlink.MAVLink_message:
    """The newest LOCAL_POSITION_NED (drains older ones queued in the socket)."""
    msg = master.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=5.0)
    if msg is None:
        raise TimeoutError("no LOCAL_POSITION_NED")
    while (newer := master.recv_match(type="LOCAL_POSITION_NED", blocking=False)) is not None:
        msg = newer
    return msg


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicle", type=int, default=1, help="sim vehicle (system id)")
    parser.add_argument("--base-port", type=int, default=14550)
    parser.add_argument("--alt", type=float, default=30.0, help="take-off altitude (m)")
    parser.add_argument("--north", type=float, default=100.0, help="target north of home (m)")
    parser.add_argument("--east", type=float, default=50.0, help="target east of home (m)")
    parser.add_argument("--timeout", type=float, default=300.0, help="give up after (s)")
    args = parser.parse_args()

    port = args.base_port + 10 * (args.vehicle - 1)
    master = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    heartbeat = master.wait_heartbeat(timeout=30)
    if heartbeat is None:
        print(f"no heartbeat on udpin:127.0.0.1:{port}", file=sys.stderr)
        return 1
    print(f"heartbeat from system {master.target_system}, type {heartbeat.type}")
    master.set_mode("GUIDED")
    master.arducopter_arm()
    master.motors_armed_wait()
    master.mav.command_long_send(
        master.target_system, 1, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, args.alt
    )
    if wait_ack(master, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF) != 0:
        print("takeoff rejected", file=sys.stderr)
        return 1
    deadline = time.monotonic() + args.timeout
    while -local_position(master).z < args.alt - 1.0:
        if time.monotonic() > deadline:
            raise TimeoutError("takeoff took too long")
    target = (args.north, args.east, -args.alt)
    print(f"climbed to {args.alt} m; flying to north {args.north} m, east {args.east} m")
    while True:
        master.mav.set_position_target_local_ned_send(
            0, master.target_system, 1, mavutil.mavlink.MAV_FRAME_LOCAL_NED,
            0b110111111000, *target, 0, 0, 0, 0, 0, 0, 0, 0,
        )  # fmt: skip
        pos = local_position(master)
        print(
            f"t={pos.time_boot_ms / 1000:7.1f} s  N {pos.x:7.1f}  E {pos.y:7.1f}  alt {-pos.z:5.1f}"
        )
        if math.dist((pos.x, pos.y, pos.z), target) < 2.0:
            break
        if time.monotonic() > deadline:
            raise TimeoutError("target not reached")
        time.sleep(0.2)
    print("target reached; landing")
    master.set_mode("LAND")
    master.motors_disarmed_wait()
    print(f"landed and disarmed at N {pos.x:.1f} E {pos.y:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
