#!/usr/bin/env python3
"""Fly one ridsafe sim vehicle in GUIDED with plain pymavlink, as any ground station would.

Start the sim first (``ridsafe sim``), then:

    python examples/fly_guided.py --vehicle 2

Vehicle i streams to udpin:127.0.0.1:(14550 + 10 (i - 1)), exactly like ArduPilot SITL
instance i - 1, so this script works unchanged against ArduCopter SITL: it asks for the
telemetry it reads (a real ArduCopter streams nothing unasked), and retries arming while
the autopilot is still starting ("Arm: Need Position Estimate" for ~40 s after boot).
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


def request_streams(master: mavutil.mavfile) -> None:
    """LOCAL_POSITION_NED at 5 Hz (SET_MESSAGE_INTERVAL), POSITION streams as a fallback."""
    master.mav.command_long_send(
        master.target_system, 1, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
        mavutil.mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 200_000, 0, 0, 0, 0, 0,
    )  # fmt: skip
    if wait_ack(master, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL) != 0:
        master.mav.request_data_stream_send(
            master.target_system, 1, mavutil.mavlink.MAV_DATA_STREAM_POSITION, 5, 1
        )


def set_guided(master: mavutil.mavfile, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        master.set_mode("GUIDED")
        hb = master.recv_match(type="HEARTBEAT", blocking=True, timeout=2.0)
        if hb is not None and master.flightmode == "GUIDED":
            return
    raise TimeoutError("the vehicle did not enter GUIDED")


def arm(master: mavutil.mavfile, timeout_s: float) -> None:
    """Arm, retrying every 2 s while the autopilot refuses (its STATUSTEXT says why)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        master.arducopter_arm()
        if wait_ack(master, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM) == 0:
            master.motors_armed_wait()
            return
        text = master.recv_match(type="STATUSTEXT", blocking=True, timeout=2.0)
        print(f"arming refused: {text.text if text else 'no reason given'}; retrying")
    raise TimeoutError(f"arming refused for {timeout_s:.0f} s")


def arm_and_take_off(master: mavutil.mavfile, alt_m: float, timeout_s: float) -> bool:
    """Arm and take off; a take-off refused just after arming (the autopilot still settling,
    or it disarmed again) is retried from arming until ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        arm(master, max(deadline - time.monotonic(), 1.0))
        master.mav.command_long_send(
            master.target_system, 1, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0,
            alt_m,
        )  # fmt: skip
        if wait_ack(master, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF) == 0:
            return True
        text = master.recv_match(type="STATUSTEXT", blocking=True, timeout=2.0)
        print(f"takeoff refused: {text.text if text else 'no reason given'}; retrying")
    return False


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
    parser.add_argument(
        "--arm-timeout", type=float, default=120.0, help="keep retrying arming this long (s)"
    )
    args = parser.parse_args()

    port = args.base_port + 10 * (args.vehicle - 1)
    master = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    heartbeat = master.wait_heartbeat(timeout=30)
    if heartbeat is None:
        print(f"no heartbeat on udpin:127.0.0.1:{port}", file=sys.stderr)
        return 1
    print(f"heartbeat from system {master.target_system}, type {heartbeat.type}")
    request_streams(master)
    set_guided(master, 30.0)
    if not arm_and_take_off(master, args.alt, args.arm_timeout):
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
