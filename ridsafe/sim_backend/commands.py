"""The sim autopilot's command table: MAV_CMD -> handler, for COMMAND_LONG and COMMAND_INT.

Every command gets one COMMAND_ACK; commands not in ``COMMAND_HANDLERS`` are answered
MAV_RESULT_UNSUPPORTED, as ArduPilot does. ``Command`` is the one view of both forms:
COMMAND_INT's position rides in ``params[4:7]`` (degrees for global frames) and ``frame``
says which; a COMMAND_LONG has ``frame`` None. Commands that need a position frame
(DO_REPOSITION) are refused in COMMAND_LONG form, as on ArduPilot.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.frozen import quick_init
from ridsafe.common.messages import CopterMode, MavCmd, MavResult

if TYPE_CHECKING:
    from ridsafe.sim_backend.autopilot import Autopilot

FloatArray = NDArray[np.float64]
FORCE_DISARM_MAGIC = 21196.0

# MAV_CMD ids beyond ``MavCmd`` (common.xml values).
DO_CHANGE_SPEED = 178
DO_REPOSITION = 192
GET_HOME_POSITION = 410
MISSION_START = 300
REQUEST_AUTOPILOT_CAPABILITIES = 520
AUTOPILOT_VERSION_ID = 148
HOME_POSITION_ID = 242
REPOSITION_CHANGE_MODE = 1  # MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
# Frames a position command may use: global, altitude relative to home (plain and _INT).
GLOBAL_FRAMES = frozenset({0, 3, 5, 6})
RELATIVE_ALT_FRAMES = frozenset({3, 6})


@dataclass(frozen=True)
class Command:
    command: int
    params: pm.Params7
    frame: int | None = None

    @classmethod
    def of(cls, msg: m.CommandLong | pm.CommandInt) -> Command:
        if isinstance(msg, pm.CommandInt):
            return cls(msg.command, msg.params, msg.frame)
        return cls(msg.command, msg.params)


@quick_init
@dataclass(frozen=True)
class VehicleSample:
    """One vehicle's truth at a tick, in the scenario ENU frame."""

    p_enu_m: FloatArray
    v_enu_m_s: FloatArray
    psi_rad: float
    on_ground: bool


@dataclass(frozen=True)
class Outcome:
    """A command's result and, for rejections, the reason ArduPilot would print."""

    result: MavResult
    reason: str = ""


ACCEPTED = Outcome(MavResult.ACCEPTED)


class TelemetryControl(Protocol):
    """The requesting link's telemetry schedule (MAV_CMD_SET_MESSAGE_INTERVAL and friends)."""

    def set_interval(self, msg_id: int, interval_us: float) -> bool: ...
    def request_once(self, msg_id: int) -> bool: ...


@quick_init
@dataclass(frozen=True)
class CommandContext:
    now_s: float
    sample: VehicleSample
    telemetry: TelemetryControl


Handler = Callable[["Autopilot", Command, CommandContext], Outcome]


def _cmd_arm_disarm(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    arm, force = cmd.params[0], cmd.params[1]
    if arm == 1.0:
        return ap.arm(ctx)
    if arm == 0.0:
        return ap.disarm(force == FORCE_DISARM_MAGIC, ctx)
    return Outcome(MavResult.DENIED, f"Arm/disarm: param1 {arm} is neither 0 nor 1")


def _cmd_takeoff(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    return ap.takeoff(cmd.params[6], ctx)


def _cmd_set_mode(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    if not int(cmd.params[0]) & m.MavModeFlag.CUSTOM_MODE_ENABLED:
        return Outcome(MavResult.DENIED, "Set mode: only custom modes are supported")
    return ap.set_mode(cmd.params[1], ctx)


def _cmd_land(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    return ap.set_mode(CopterMode.LAND, ctx)


def _cmd_rtl(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    return ap.set_mode(CopterMode.RTL, ctx)


def _cmd_message_interval(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    msg_id, interval_us = cmd.params[0], cmd.params[1]
    if not (math.isfinite(msg_id) and math.isfinite(interval_us)):
        return Outcome(MavResult.DENIED, "Message interval: non-finite parameter")
    if ctx.telemetry.set_interval(int(msg_id), interval_us):
        return ACCEPTED
    return Outcome(MavResult.FAILED, f"Message interval: message {int(msg_id)} not streamed")


def _cmd_request_message(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    msg_id = cmd.params[0]
    if math.isfinite(msg_id) and ctx.telemetry.request_once(int(msg_id)):
        return ACCEPTED
    return Outcome(MavResult.FAILED, f"Request message: {msg_id} not available")


def _cmd_request_capabilities(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    ctx.telemetry.request_once(AUTOPILOT_VERSION_ID)
    return ACCEPTED


def _cmd_get_home(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    ctx.telemetry.request_once(HOME_POSITION_ID)
    return ACCEPTED


def _cmd_reposition(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    if cmd.frame is None:
        return Outcome(MavResult.UNSUPPORTED, "Reposition: send it as COMMAND_INT")
    if cmd.frame not in GLOBAL_FRAMES:
        return Outcome(MavResult.DENIED, f"Reposition: frame {cmd.frame} unsupported")
    change_mode = int(cmd.params[1]) & REPOSITION_CHANGE_MODE if math.isfinite(cmd.params[1]) else 0
    if ap.mode is not CopterMode.GUIDED:
        if not change_mode:
            return Outcome(MavResult.DENIED, "Reposition: not in GUIDED")
        outcome = ap.set_mode(CopterMode.GUIDED, ctx)
        if outcome.result is not MavResult.ACCEPTED:
            return outcome
    speed = cmd.params[0]
    if math.isfinite(speed) and speed > 0:
        ap.params.set("WPNAV_SPEED", speed * 100.0)
    return ap.go_to_global(cmd.params[4], cmd.params[5], cmd.params[6], cmd.frame, ctx)


def _cmd_change_speed(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    speed = cmd.params[1]
    if not (math.isfinite(speed) and speed > 0):
        return Outcome(MavResult.DENIED, f"Change speed: {speed} m/s")
    ap.params.set("WPNAV_SPEED", speed * 100.0)
    return ACCEPTED


def _cmd_mission_start(ap: Autopilot, cmd: Command, ctx: CommandContext) -> Outcome:
    return ap.set_mode(CopterMode.AUTO, ctx)


COMMAND_HANDLERS: dict[int, Handler] = {
    MavCmd.COMPONENT_ARM_DISARM: _cmd_arm_disarm,
    MavCmd.NAV_TAKEOFF: _cmd_takeoff,
    MavCmd.DO_SET_MODE: _cmd_set_mode,
    MavCmd.NAV_LAND: _cmd_land,
    MavCmd.NAV_RETURN_TO_LAUNCH: _cmd_rtl,
    MavCmd.SET_MESSAGE_INTERVAL: _cmd_message_interval,
    MavCmd.REQUEST_MESSAGE: _cmd_request_message,
    REQUEST_AUTOPILOT_CAPABILITIES: _cmd_request_capabilities,
    GET_HOME_POSITION: _cmd_get_home,
    DO_REPOSITION: _cmd_reposition,
    DO_CHANGE_SPEED: _cmd_change_speed,
    MISSION_START: _cmd_mission_start,
}
