#!/usr/bin/env python3
"""Fly one ridsafe sim vehicle in GUIDED with plain pymavlink, as any ground station would.

Start the sim first (``ridsafe sim``), then:

    python examples/fly_guided.py --vehicle 2

Vehicle i streams to udpin:127.0.0.1:(14550 + 10 (i - 1)), exactly like ArduPilot SITL
instance i - 1, so this script works unchanged against ArduCopter SITL: it asks for the
telemetry it reads (a real ArduCopter streams nothing unasked), and retries arming at a
steady pace while the autopilot is still starting ("Arm: Need Position Estimate" for ~40 s
after boot), saying why each try was refused, until ``--arm-timeout``.

Retries are paced (``--arm-retry``, 2 s): an autopilot answers a refused arm at once, and a
client that retries on every answer floods it with arming checks; a loaded ArduCopter SITL
then overruns its main loop and its inertial sensors never pass their 10 s consistency
check ("Arm: Gyros inconsistent" for minutes).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

mav = mavutil.mavlink
ACCEPTED = mav.MAV_RESULT_ACCEPTED
ARM_TEXT_PREFIXES = ("Arm:", "PreArm:")


def wait_ack(master: mavutil.mavfile, command: int, timeout_s: float = 10.0) -> tuple[int, str]:
    """The result of ``command``'s COMMAND_ACK and the last arming/pre-arm STATUSTEXT seen
    while waiting for it (an autopilot says why it refused in a STATUSTEXT)."""
    reason = ""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = master.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=0.5)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            if msg.text.startswith(ARM_TEXT_PREFIXES):
                reason = msg.text
        elif msg.command == command:
            return int(msg.result), reason
    raise TimeoutError(f"no COMMAND_ACK for command {command} in {timeout_s:g} s")


def result_name(result: int) -> str:
    return (
        str(mav.enums["MAV_RESULT"][result].name)
        if result in mav.enums["MAV_RESULT"]
        else str(result)
    )


def collect_reason(master: mavutil.mavfile, until: float, reason: str) -> str:
    """Read (and keep the newest arming reason of) everything that arrives until ``until``."""
    while (left := until - time.monotonic()) > 0:
        msg = master.recv_match(type="STATUSTEXT", blocking=True, timeout=min(left, 0.5))
        if msg is not None and msg.text.startswith(ARM_TEXT_PREFIXES):
            reason = msg.text
    return reason


def request_streams(master: mavutil.mavfile, tries: int = 3) -> None:
    """LOCAL_POSITION_NED at 5 Hz (SET_MESSAGE_INTERVAL, asked again while unanswered: an
    autopilot still starting may drop it), POSITION streams as a fallback."""
    for _ in range(tries):
        master.mav.command_long_send(
            master.target_system, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
            mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 200_000, 0, 0, 0, 0, 0,
        )  # fmt: skip
        try:
            if wait_ack(master, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 5.0)[0] == ACCEPTED:
                return
            break
        except TimeoutError:
            print("no answer to SET_MESSAGE_INTERVAL yet; asking again", flush=True)
    master.mav.request_data_stream_send(master.target_system, 1, mav.MAV_DATA_STREAM_POSITION, 5, 1)


def enter_guided(master: mavutil.mavfile, timeout_s: float = 3.0) -> bool:
    """Ask for GUIDED until a HEARTBEAT shows it or ``timeout_s`` passes. Asked again before
    every arming try: an ArduCopter still initialising accepts GUIDED, then starts up in its
    initial mode (STABILIZE), and arming there would be accepted with no position estimate."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if master.flightmode == "GUIDED":
            return True
        master.set_mode("GUIDED")
        master.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
    return master.flightmode == "GUIDED"


def wait_armed_state(master: mavutil.mavfile, armed: bool, timeout_s: float) -> bool:
    """True once a HEARTBEAT says the motors are (dis)armed as asked, False after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        hb = master.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
        if (
            hb is not None
            and (hb.get_srcSystem(), hb.get_srcComponent()) == (master.target_system, 1)
            and bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED) == armed
        ):
            return True
    return False


def try_arm_in_guided(master: mavutil.mavfile) -> str:
    """One arming try in GUIDED: "" once armed in GUIDED, else why not."""
    if not enter_guided(master):
        return f"still in {master.flightmode}, GUIDED not accepted yet"
    master.arducopter_arm()
    result, reason = wait_ack(master, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    if result != ACCEPTED:
        return reason or f"{result_name(result)}, no reason given"
    if not wait_armed_state(master, True, 10.0):
        return "arming accepted but no armed HEARTBEAT"
    if master.flightmode != "GUIDED":  # never fly on from another mode: disarm, try again
        master.arducopter_disarm()
        wait_armed_state(master, False, 10.0)
        return f"armed in {master.flightmode}, not GUIDED; disarmed"
    return ""


def arm(master: mavutil.mavfile, give_up_s: float, retry_s: float) -> None:
    """Arm in GUIDED, one try every ``retry_s`` while the autopilot refuses, saying why, until
    ``give_up_s``."""
    start = time.monotonic()
    while True:
        tried = time.monotonic()
        reason = try_arm_in_guided(master)
        if not reason:
            return
        reason = collect_reason(master, tried + retry_s, reason)
        waited = time.monotonic() - start
        if waited + retry_s > give_up_s:
            raise TimeoutError(
                f"arming refused for {waited:.0f} s (last: {reason}); giving up (--arm-timeout)"
            )
        print(
            f"arming refused after {waited:4.0f} s: {reason}; "
            f"retrying every {retry_s:g} s until {give_up_s:g} s",
            flush=True,
        )


def arm_and_take_off(master: mavutil.mavfile, alt_m: float, give_up_s: float,
                     retry_s: float) -> None:  # fmt: skip
    """Arm and take off; a take-off refused just after arming (the autopilot still settling,
    or it disarmed again) is retried from arming until ``give_up_s``."""
    deadline = time.monotonic() + give_up_s
    while True:
        arm(master, max(deadline - time.monotonic(), retry_s), retry_s)
        tried = time.monotonic()
        master.mav.command_long_send(
            master.target_system, 1, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, alt_m
        )
        result, reason = wait_ack(master, mav.MAV_CMD_NAV_TAKEOFF)
        if result == ACCEPTED:
            return
        reason = collect_reason(master, tried + retry_s, reason)
        if time.monotonic() > deadline:
            raise TimeoutError(f"take-off refused (last: {reason or 'no reason given'})")
        print(f"takeoff refused ({result_name(result)}): {reason or 'no reason given'}; "
              "retrying", flush=True)  # fmt: skip


def local_position(master: mavutil.mavfile, timeout_s: float = 5.0) -> Any:
    """The newest LOCAL_POSITION_NED (drains older ones queued in the socket)."""
    msg = master.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=timeout_s)
    if msg is None:
        raise TimeoutError(f"no LOCAL_POSITION_NED for {timeout_s:g} s")
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
    parser.add_argument("--timeout", type=float, default=300.0, help="flight give-up (s)")
    parser.add_argument(
        "--arm-timeout", type=float, default=180.0, help="keep retrying arming this long (s)"
    )
    parser.add_argument("--arm-retry", type=float, default=2.0, help="one arming try per (s)")
    args = parser.parse_args()

    port = args.base_port + 10 * (args.vehicle - 1)
    master = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    print(f"listening on udpin:127.0.0.1:{port} for the vehicle's heartbeat", flush=True)
    heartbeat = master.wait_heartbeat(timeout=30)
    if heartbeat is None:
        print(f"no heartbeat on udpin:127.0.0.1:{port}", file=sys.stderr)
        return 1
    print(f"heartbeat from system {master.target_system}, type {heartbeat.type}", flush=True)
    try:
        request_streams(master)
        arm_and_take_off(master, args.alt, args.arm_timeout, args.arm_retry)
        deadline = time.monotonic() + args.timeout
        while -local_position(master).z < args.alt - 1.0:
            if time.monotonic() > deadline:
                raise TimeoutError("takeoff took too long")
        target = (args.north, args.east, -args.alt)
        print(f"climbed to {args.alt} m; flying to north {args.north} m, east {args.east} m")
        while True:
            master.mav.set_position_target_local_ned_send(
                0, master.target_system, 1, mav.MAV_FRAME_LOCAL_NED,
                0b110111111000, *target, 0, 0, 0, 0, 0, 0, 0, 0,
            )  # fmt: skip
            pos = local_position(master)
            print(f"t={pos.time_boot_ms / 1000:7.1f} s  N {pos.x:7.1f}  E {pos.y:7.1f}  "
                  f"alt {-pos.z:5.1f}", flush=True)  # fmt: skip
            if math.dist((pos.x, pos.y, pos.z), target) < 2.0:
                break
            if time.monotonic() > deadline:
                raise TimeoutError("target not reached")
            time.sleep(0.2)
        print("target reached; landing", flush=True)
        master.set_mode("LAND")
        if not wait_armed_state(master, False, max(deadline - time.monotonic(), 60.0)):
            raise TimeoutError("still armed after landing time")
    except TimeoutError as gave_up:
        print(f"gave up: {gave_up}", file=sys.stderr)
        return 1
    print(f"landed and disarmed at N {pos.x:.1f} E {pos.y:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
