"""The sim autopilot's mode and check tables (data, read by :class:`~.autopilot.Autopilot`).

- ``MODE_RULES``: per ArduCopter mode, whether arming is allowed, whether GUIDED targets are
  accepted, and what the vehicle does in the air (``Behaviour``). Modes ArduCopter has and
  the sim lacks (ACRO, CIRCLE, POSHOLD, ...) are refused on a mode change, as ArduCopter
  refuses a mode it cannot enter; every mode here but RTL, LAND and AUTO-without-mission
  leaves the vehicle armable.
- ``ARM_CHECKS`` and ``TAKEOFF_CHECKS``: ordered (predicate, result, reason) rows; the first
  failing row decides the rejection, as ArduPilot's pre-arm and takeoff checks do.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

from ridsafe.common.messages import CopterMode, MavResult
from ridsafe.sim_backend.commands import CommandContext

if TYPE_CHECKING:
    from ridsafe.sim_backend.autopilot import Autopilot

Check = tuple[Callable[["Autopilot", CommandContext], bool], MavResult, str]


class Behaviour(Enum):
    """What a mode makes the vehicle do once it is in the air."""

    GUIDED = "follow targets"
    HOLD = "hold position"
    LAND = "descend and disarm"
    RTL = "return home and land"
    MISSION = "fly the scripted mission"


@dataclass(frozen=True)
class ModeRule:
    """``guided_flag``: HEARTBEAT.base_mode carries MAV_MODE_FLAG_GUIDED_ENABLED (as
    ArduCopter sets it for its position-controlled modes). As on ArduCopter, a disarmed
    vehicle may enter them before it has a position estimate (mode checks apply when armed)."""

    armable: bool
    accepts_targets: bool
    behaviour: Behaviour
    guided_flag: bool


MODE_RULES: dict[CopterMode, ModeRule] = {
    CopterMode.STABILIZE: ModeRule(True, False, Behaviour.HOLD, guided_flag=False),
    CopterMode.ALT_HOLD: ModeRule(True, False, Behaviour.HOLD, guided_flag=False),
    CopterMode.GUIDED: ModeRule(True, True, Behaviour.GUIDED, guided_flag=True),
    CopterMode.LOITER: ModeRule(True, False, Behaviour.HOLD, guided_flag=True),
    CopterMode.AUTO: ModeRule(True, False, Behaviour.MISSION, guided_flag=True),
    CopterMode.RTL: ModeRule(False, False, Behaviour.RTL, guided_flag=True),
    CopterMode.LAND: ModeRule(False, False, Behaviour.LAND, guided_flag=False),
    CopterMode.BRAKE: ModeRule(True, False, Behaviour.HOLD, guided_flag=True),
}


ARM_CHECKS: tuple[Check, ...] = (
    (
        lambda ap, ctx: MODE_RULES[ap.mode].armable,
        MavResult.FAILED,
        "Arm: Mode not armable",
    ),
    (
        lambda ap, ctx: ctx.sample.on_ground,
        MavResult.FAILED,
        "Arm: vehicle is not on the ground",
    ),
    (
        lambda ap, ctx: (
            ap.params.get("ARMING_CHECK") == 0 or ctx.now_s >= ap.params.get("SIM_PREARM_T")
        ),
        MavResult.FAILED,
        "Arm: Need Position Estimate",
    ),
    (
        lambda ap, ctx: (
            ap.params.get("ARMING_CHECK") == 0
            or ap._remote_id_error is None
            or not ap.config.require_remote_id_to_arm
            or ap._remote_id_error(ctx.now_s) is None
        ),
        MavResult.FAILED,
        "PreArm: Remote ID not ready",
    ),
)

TAKEOFF_CHECKS: tuple[Check, ...] = (
    (lambda ap, ctx: ap.armed, MavResult.FAILED, "Takeoff: vehicle is disarmed"),
    (
        lambda ap, ctx: MODE_RULES[ap.mode].accepts_targets,
        MavResult.FAILED,
        "Takeoff: mode is not GUIDED",
    ),
    (lambda ap, ctx: ctx.sample.on_ground, MavResult.FAILED, "Takeoff: already flying"),
)
