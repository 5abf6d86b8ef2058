"""One simulated autopilot per vehicle that a MAVLink client takes for ArduCopter.

Sans I/O: the backend hands it decoded domain messages and a per-tick ``VehicleSample``;
it answers with domain messages and moves the vehicle through the ``Actuators`` protocol
(arm, disarm, set_target). Its behaviour is data:

- ``MODE_RULES``: per ArduCopter mode, whether arming is allowed, whether GUIDED targets are
  accepted, and what the vehicle does in the air (``Behaviour``).
- ``COMMAND_HANDLERS``: MAV_CMD -> handler; every COMMAND_LONG gets a COMMAND_ACK, with
  MAV_RESULT_UNSUPPORTED for commands not in the table.
- ``TAKEOFF_CHECKS`` and ``ARM_CHECKS``: ordered (predicate, result, reason) rows; the first
  failing row decides the rejection, as ArduPilot's pre-arm and takeoff checks do.

Frames: the vehicle's local NED frame is the tangent frame at its home (where it stood at
start); the sim's truth is the scenario ENU frame. ``HomeFrame`` maps between them exactly
(both are rigid transforms of ECEF).

Parameters are ArduCopter's names (:mod:`.param_table`, read at each use, so PARAM_SET acts
at once); uploaded missions fly in AUTO (:mod:`.auto_mission`), the spoofer's scripted
``Mission`` overrides them. Companion loss: a SET_POSITION_TARGET stream that stops for
``SIM_OFB_LOSS_T`` in GUIDED, in the air, makes the vehicle LAND (or RTL / hold), logged
as an event. Behaviour that ArduCopter has and this does not: no RC input (STABILIZE and
ALT_HOLD hold position in the air, like LOITER), no geofence, no terrain.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.messages import CopterMode, MavResult
from ridsafe.common.messages import PositionTargetMask as Mask
from ridsafe.sim_backend.auto_mission import AutoMission
from ridsafe.sim_backend.commands import (
    ACCEPTED,
    COMMAND_HANDLERS,
    FORCE_DISARM_MAGIC,
    RELATIVE_ALT_FRAMES,
    Command,
    CommandContext,
    Outcome,
    TelemetryControl,
    VehicleSample,
)
from ridsafe.sim_backend.fence import Fence
from ridsafe.sim_backend.home_frame import HomeFrame
from ridsafe.sim_backend.mission_protocol import MissionStore
from ridsafe.sim_backend.mode_rules import (
    ARM_CHECKS,
    MODE_RULES,
    TAKEOFF_CHECKS,
    Behaviour,
    ModeRule,
)
from ridsafe.sim_backend.param_table import FailsafeAction, ParamStore
from ridsafe.sim_backend.params import ControllerParams
from ridsafe.sim_backend.targets import (
    BODY_FRAMES,
    POSITION_BITS,
    TARGET_FRAMES,
    VELOCITY_BITS,
    mask_rejection,
    yaw_rotate,
)
from ridsafe.sim_backend.wpnav import WaypointNav

logger = logging.getLogger(__name__)
PREARM_REPORT_PERIOD_S = 30.0

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class AutopilotConfig:
    """ArduCopter-like behaviour constants (names after the ArduCopter parameters)."""

    failsafe_timeout_s: float = 3.0  # GUIDED velocity target lapses -> hold position
    rtl_alt_m: float = 15.0  # RTL_ALT
    land_speed_m_s: float = 0.5  # LAND_SPEED, final descent
    land_speed_high_m_s: float = 1.5  # LAND_SPEED_HIGH / WPNAV_SPEED_DN, above 10 m
    land_final_alt_m: float = 10.0
    rtl_speed_m_s: float = 5.0  # RTL_SPEED / WPNAV_SPEED
    disarm_delay_s: float = 10.0  # DISARM_DELAY: armed on the ground without taking off
    takeoff_alt_max_m: float = 500.0
    max_target_distance_m: float = 50_000.0  # farther targets are rejected as out of range
    max_target_speed_m_s: float = 100.0  # faster targets are rejected; <= this is clipped to 8
    require_remote_id_to_arm: bool = False  # ArduPilot's DID_OPTIONS enforcement
    # Companion loss: a setpoint stream (two or more SET_POSITION_TARGET_*) that stops for
    # this long in GUIDED, in the air, triggers ``companion_loss_action`` (0 disables).
    companion_loss_timeout_s: float = 10.0  # SIM_OFB_LOSS_T
    companion_loss_action: FailsafeAction = FailsafeAction.LAND  # SIM_OFB_LOSS_ACT
    # No position estimate for this long after start (SIM_PREARM_T): arming refused with
    # "Arm: Need Position Estimate", "PreArm: ..." every 30 s, as a real ArduCopter's ~40 s.
    prearm_delay_s: float = 0.0


class Actuators(Protocol):
    """What the autopilot may do to its vehicle (``OctorotorFleet`` provides it)."""

    def arm(self, vehicle: int) -> None: ...
    def disarm(self, vehicle: int) -> None: ...
    def set_target(
        self,
        vehicle: int,
        *,
        position_enu_m: ArrayLike | None = None,
        velocity_enu_m_s: ArrayLike | None = None,
        yaw_rad: float | None = None,
    ) -> None: ...


class Mission(Protocol):
    """A scripted flight for AUTO mode: the target at a given time."""

    def target(self, now_s: float) -> tuple[FloatArray, FloatArray]:
        """(position_enu_m (3,), velocity_enu_m_s (3,))."""
        ...


class Autopilot:
    """Modes, arming, commands, GUIDED targets and failsafes of one vehicle (index ``vehicle``)."""

    def __init__(
        self,
        sysid: int,
        vehicle: int,
        home: HomeFrame,
        actuators: Actuators,
        config: AutopilotConfig | None = None,
        mission: Mission | None = None,
        remote_id_error: Callable[[float], str | None] | None = None,
        controller: ControllerParams | None = None,
    ) -> None:
        """``controller``: the vehicle controller's parameters; given, a WPNAV_SPEED below its
        speed cap limits position-only targets (:mod:`.wpnav`)."""
        self.sysid = sysid
        self.vehicle = vehicle
        self.home = home
        self.config: AutopilotConfig = config if config is not None else AutopilotConfig()
        self.mission = mission
        self.actuators = actuators
        self._remote_id_error: Callable[[float], str | None] | None = remote_id_error
        self.mode: CopterMode = CopterMode.STABILIZE
        self.armed: bool = False
        self.takeoff_alt_enu_m: float | None = None
        self.last_target_s = -math.inf
        self.target_has_velocity = False
        self.armed_at_s = 0.0
        self.landed_since_s: float | None = None
        self.failsafe_active = False
        self.rejected_targets = 0
        self.params: ParamStore = ParamStore(self.config, sysid)
        self.wpnav: WaypointNav | None = None
        if controller is not None:
            self.wpnav = WaypointNav(actuators, self.params, controller)
            self.actuators = self.wpnav
        self.missions = MissionStore()
        self.auto: AutoMission | None = None
        self.setpoints_in_stream = 0
        self.failsafes = 0
        self._next_prearm_text_s = 0.0
        self._events: list[dict[str, object]] = []
        self._hold_enu_m: FloatArray | None = None
        self._status: list[m.StatusText] = []
        self.fence = Fence()

    # -- what the vehicle says ------------------------------------------------------------

    def heartbeat(self) -> m.Heartbeat:
        base = (
            m.MavModeFlag.CUSTOM_MODE_ENABLED
            | m.MavModeFlag.STABILIZE_ENABLED
            | m.MavModeFlag.MANUAL_INPUT_ENABLED
        )
        if MODE_RULES[self.mode].guided_flag:
            base |= m.MavModeFlag.GUIDED_ENABLED
        if self.armed:
            base |= m.MavModeFlag.SAFETY_ARMED
        state = m.MavState.ACTIVE if self.armed else m.MavState.STANDBY
        return m.Heartbeat(
            m.MavType.OCTOROTOR, m.MavAutopilot.ARDUPILOTMEGA, int(base), int(self.mode), state
        )

    def take_events(self) -> list[dict[str, object]]:
        """Failsafe events since the last call (``{sysid, event, action, mode}``)."""
        out, self._events = self._events, []
        return out

    def prearm_ok(self, now_s: float) -> bool:
        """The pre-arm checks that do not depend on mode or flight state pass."""
        if self.params.get("ARMING_CHECK") == 0:
            return True
        if now_s < self.params.get("SIM_PREARM_T"):
            return False
        rid = self._remote_id_error
        return rid is None or not self.config.require_remote_id_to_arm or rid(now_s) is None

    def take_status(self) -> list[m.StatusText]:
        """STATUSTEXT messages produced since the last call."""
        out, self._status = self._status, []
        return out

    def _say(self, severity: m.MavSeverity, text: str) -> None:
        """Log ``text`` and queue it as STATUSTEXT (which carries at most 50 characters)."""
        logger.info("vehicle %d: %s", self.sysid, text)
        self._status.append(m.StatusText(int(severity), text[:50]))

    # -- commands --------------------------------------------------------------------------

    def handle_command(
        self, msg: m.CommandLong | pm.CommandInt, ctx: CommandContext
    ) -> m.CommandAck:
        cmd = Command.of(msg)
        handler = COMMAND_HANDLERS.get(cmd.command)
        if handler is None:
            outcome = Outcome(MavResult.UNSUPPORTED, f"Unsupported command {cmd.command}")
        else:
            outcome = handler(self, cmd, ctx)
        if outcome.result is not MavResult.ACCEPTED and outcome.reason:
            self._say(m.MavSeverity.WARNING, outcome.reason)
        return m.CommandAck(cmd.command, int(outcome.result), 0, 0)

    def handle_set_mode(self, msg: m.SetMode, ctx: CommandContext) -> m.CommandAck:
        """Legacy SET_MODE; ArduPilot answers it with a COMMAND_ACK for command id 11."""
        outcome = self.set_mode(msg.custom_mode, ctx)
        if outcome.reason:
            self._say(m.MavSeverity.WARNING, outcome.reason)
        return m.CommandAck(11, int(outcome.result), 0, 0)

    def set_mode(self, custom_mode: float, ctx: CommandContext) -> Outcome:
        if not math.isfinite(custom_mode) or int(custom_mode) != custom_mode:
            return Outcome(MavResult.DENIED, f"Invalid mode {custom_mode}")
        try:
            mode = CopterMode(int(custom_mode))
        except ValueError:
            return Outcome(MavResult.FAILED, f"Mode change to {int(custom_mode)} failed")
        if mode not in MODE_RULES:
            return Outcome(MavResult.FAILED, f"Mode change to {mode.name} failed")
        auto = MODE_RULES[mode].behaviour is Behaviour.MISSION and self.mission is None
        if auto and mode is not self.mode:
            items = self.missions.nav_items()
            if not items:
                return Outcome(MavResult.FAILED, "Mode change to AUTO failed: no mission")
            self.auto = AutoMission(items, max(self.missions.current_seq, 1))
        if mode is not self.mode:
            self.mode = mode
            self.failsafe_active = False
            self.setpoints_in_stream = 0
            self._hold_enu_m = ctx.sample.p_enu_m.copy()
            self._say(m.MavSeverity.INFO, f"Mode {mode.name}")
        return ACCEPTED

    def arm(self, ctx: CommandContext) -> Outcome:
        if self.armed:
            return ACCEPTED
        for predicate, result, reason in ARM_CHECKS:
            if not predicate(self, ctx):
                return Outcome(result, reason)
        self.armed = True
        self.armed_at_s = ctx.now_s
        self.takeoff_alt_enu_m = None
        self._hold_enu_m = ctx.sample.p_enu_m.copy()
        self.actuators.set_target(
            self.vehicle, position_enu_m=ctx.sample.p_enu_m, yaw_rad=ctx.sample.psi_rad
        )
        self.actuators.arm(self.vehicle)
        self._say(m.MavSeverity.INFO, "Arming motors")
        return ACCEPTED

    def disarm(self, force: bool, ctx: CommandContext) -> Outcome:
        if not self.armed:
            return ACCEPTED
        if not ctx.sample.on_ground and not force:
            return Outcome(MavResult.FAILED, "Disarm: vehicle is flying")
        self._disarm(ctx.now_s)
        return ACCEPTED

    def _disarm(self, now_s: float) -> None:
        self.armed = False
        self.takeoff_alt_enu_m = None
        self.actuators.disarm(self.vehicle)
        self._say(m.MavSeverity.INFO, f"Disarming motors at {now_s:.1f} s")

    def takeoff(self, alt_rel_m: float, ctx: CommandContext) -> Outcome:
        for predicate, result, reason in TAKEOFF_CHECKS:
            if not predicate(self, ctx):
                return Outcome(result, reason)
        if not (math.isfinite(alt_rel_m) and 0.0 < alt_rel_m <= self.config.takeoff_alt_max_m):
            return Outcome(MavResult.DENIED, f"Takeoff: altitude {alt_rel_m} out of range")
        self.takeoff_alt_enu_m = float(self.home.home_enu_m[2] + alt_rel_m)
        target = ctx.sample.p_enu_m.copy()
        target[2] = self.takeoff_alt_enu_m
        self.actuators.set_target(self.vehicle, position_enu_m=target, yaw_rad=ctx.sample.psi_rad)
        self.last_target_s = ctx.now_s
        self.target_has_velocity = False
        self._say(m.MavSeverity.INFO, f"Takeoff to {alt_rel_m:.1f} m")
        return ACCEPTED

    # -- GUIDED targets --------------------------------------------------------------------

    def handle_position_target(self, msg: m.SetPositionTargetLocalNed, ctx: CommandContext) -> bool:
        """Apply a SET_POSITION_TARGET_LOCAL_NED; False (logged, counted) if rejected.

        ArduPilot sends no ACK for setpoints; a rejection is a STATUSTEXT and a count.
        """
        reason = self._target_rejection(msg, ctx)
        if reason is not None:
            self.rejected_targets += 1
            self._say(m.MavSeverity.WARNING, reason)
            return False
        mask = Mask(msg.type_mask)
        position = velocity = None
        heading_rad = frames.wrap_pi(math.pi / 2 - ctx.sample.psi_rad)
        body = msg.coordinate_frame in BODY_FRAMES
        if not mask & POSITION_BITS:
            p_ned = np.asarray(msg.p_ned_m, dtype=np.float64)
            if body:
                p_ned = yaw_rotate(p_ned, heading_rad)
            if msg.coordinate_frame != m.MavFrame.LOCAL_NED:
                p_ned = p_ned + self.home.enu_to_local_ned(ctx.sample.p_enu_m)
            position = self.home.local_ned_to_enu(p_ned)
        if not mask & VELOCITY_BITS:
            v_ned = np.asarray(msg.v_ned_m_s, dtype=np.float64)
            velocity = self.home.vel_ned_to_enu(yaw_rotate(v_ned, heading_rad) if body else v_ned)
        yaw = None if mask & Mask.YAW_IGNORE else frames.wrap_pi(math.pi / 2 - msg.yaw_rad)
        if yaw is None:
            yaw = ctx.sample.psi_rad
        self.actuators.set_target(
            self.vehicle, position_enu_m=position, velocity_enu_m_s=velocity, yaw_rad=yaw
        )
        self.takeoff_alt_enu_m = None
        self.last_target_s = ctx.now_s
        self.target_has_velocity = velocity is not None
        self.failsafe_active = False
        self.setpoints_in_stream += 1
        return True

    def go_to_global(
        self, lat_deg: float, lon_deg: float, alt_m: float, frame: int, ctx: CommandContext
    ) -> Outcome:
        """Fly to a WGS-84 point and hold there (DO_REPOSITION, guided MISSION_ITEM);
        ``alt_m`` above home for the relative-altitude frames, else above the ellipsoid."""
        if not all(math.isfinite(v) for v in (lat_deg, lon_deg, alt_m)):
            return Outcome(MavResult.DENIED, "Guided: non-finite target")
        if not (abs(lat_deg) <= 90.0 and abs(lon_deg) <= 180.0):
            return Outcome(MavResult.DENIED, "Guided: latitude/longitude out of range")
        if MODE_RULES[self.mode].behaviour is not Behaviour.GUIDED:
            return Outcome(MavResult.DENIED, f"Guided: mode {self.mode.name} is not GUIDED")
        if not self.armed or (ctx.sample.on_ground and self.takeoff_alt_enu_m is None):
            return Outcome(MavResult.FAILED, "Guided: not flying (arm and take off first)")
        home = self.home.home_geodetic
        alt_msl = home.alt_m + alt_m if frame in RELATIVE_ALT_FRAMES else alt_m
        p_ned = frames.geodetic_to_ned(home, lat_deg, lon_deg, alt_msl)
        distance = float(np.max(np.abs(p_ned)))
        if distance > self.config.max_target_distance_m:
            return Outcome(MavResult.DENIED, f"Guided: {distance:.3g} m out of range")
        self.actuators.set_target(
            self.vehicle,
            position_enu_m=self.home.local_ned_to_enu(p_ned),
            yaw_rad=ctx.sample.psi_rad,
        )
        self.takeoff_alt_enu_m = None
        self.last_target_s = ctx.now_s
        self.target_has_velocity = False
        self.failsafe_active = False
        self.setpoints_in_stream = 0  # a one-shot target, not an offboard stream
        return ACCEPTED

    def _target_rejection(
        self, msg: m.SetPositionTargetLocalNed, ctx: CommandContext
    ) -> str | None:
        if not MODE_RULES[self.mode].accepts_targets:
            return f"Target: mode {self.mode.name} is not GUIDED"
        if not self.armed or (ctx.sample.on_ground and self.takeoff_alt_enu_m is None):
            return "Target: not flying (arm and take off first)"
        if msg.coordinate_frame not in TARGET_FRAMES:
            return f"Target: frame {msg.coordinate_frame} unsupported"
        return mask_rejection(
            msg, self.config.max_target_distance_m, self.config.max_target_speed_m_s
        )

    # -- every tick ------------------------------------------------------------------------

    def update(self, now_s: float, sample: VehicleSample) -> None:
        """Mode behaviour, failsafe, land detection and auto-disarm."""
        if not self.armed:
            self._prearm_report(now_s)
            return
        if sample.on_ground:
            self._on_ground(now_s)
        else:
            self.landed_since_s = None
        self.fence.update(now_s, sample, self)
        if self.wpnav is not None:
            self.wpnav.update(sample)
        behaviour = MODE_RULES[self.mode].behaviour
        if behaviour is Behaviour.GUIDED:
            self._guided_failsafe(now_s, sample)
        elif behaviour is Behaviour.LAND:
            self._land(sample)
        elif behaviour is Behaviour.RTL:
            self._rtl(sample)
        elif behaviour is Behaviour.MISSION and self.mission is not None:
            position, velocity = self.mission.target(now_s)
            self.actuators.set_target(
                self.vehicle, position_enu_m=position, velocity_enu_m_s=velocity
            )
        elif behaviour is Behaviour.MISSION and self.auto is not None:
            self.auto.update(sample, self)

    def _prearm_report(self, now_s: float) -> None:
        """Disarmed without a position estimate: say so every 30 s, as ArduCopter does."""
        if now_s < self.params.get("SIM_PREARM_T") and now_s >= self._next_prearm_text_s:
            self._next_prearm_text_s = now_s + PREARM_REPORT_PERIOD_S
            self._say(m.MavSeverity.CRITICAL, "PreArm: Need Position Estimate")

    def _on_ground(self, now_s: float) -> None:
        if self.landed_since_s is None:
            self.landed_since_s = now_s
        landed_for = now_s - self.landed_since_s
        behaviour = MODE_RULES[self.mode].behaviour
        landing = behaviour in (Behaviour.LAND, Behaviour.RTL) or (
            behaviour is Behaviour.MISSION and self.auto is not None and self.auto.landing
        )
        idle = self.takeoff_alt_enu_m is None and min(
            landed_for, now_s - self.armed_at_s
        ) >= self.params.get("DISARM_DELAY")
        if (landing and landed_for >= 1.0) or idle:
            self._disarm(now_s)

    def _guided_failsafe(self, now_s: float, sample: VehicleSample) -> None:
        self._companion_loss(now_s, sample)
        lapsed = now_s - self.last_target_s > self.params.get("GUID_TIMEOUT")
        if self.target_has_velocity and lapsed and not self.failsafe_active:
            self.failsafe_active = True
            self.target_has_velocity = False
            self.actuators.set_target(
                self.vehicle, position_enu_m=sample.p_enu_m, yaw_rad=sample.psi_rad
            )
            self._say(
                m.MavSeverity.WARNING,
                f"No target for {self.params.get('GUID_TIMEOUT'):g} s: holding position",
            )

    def _companion_loss(self, now_s: float, sample: VehicleSample) -> None:
        """The setpoint stream stopped for SIM_OFB_LOSS_T in the air: hold, land or RTL."""
        timeout_s = self.params.get("SIM_OFB_LOSS_T")
        if timeout_s <= 0 or self.setpoints_in_stream < 2 or sample.on_ground:
            return
        silent_s = now_s - self.last_target_s
        if silent_s <= timeout_s:
            return
        action = FailsafeAction(int(self.params.get("SIM_OFB_LOSS_ACT")))
        self.setpoints_in_stream = 0
        self.failsafes += 1
        self._say(
            m.MavSeverity.CRITICAL, f"Failsafe: companion lost {silent_s:.1f} s, {action.name}"
        )
        self._events.append(
            {"sysid": self.sysid, "event": "companion_loss", "action": action.name.lower(),
             "silent_s": silent_s}
        )  # fmt: skip
        if action is FailsafeAction.HOLD:
            self.actuators.set_target(
                self.vehicle, position_enu_m=sample.p_enu_m, yaw_rad=sample.psi_rad
            )
            self.target_has_velocity = False
            self.failsafe_active = True
            return
        mode = CopterMode.LAND if action is FailsafeAction.LAND else CopterMode.RTL
        self.mode = mode
        self._hold_enu_m = sample.p_enu_m.copy()

    def say(self, severity: m.MavSeverity, text: str) -> None:
        """A STATUSTEXT from this autopilot (for its parts: fence, missions)."""
        self._say(severity, text)

    def record_event(self, event: dict[str, object]) -> None:
        self._events.append({"sysid": self.sysid, **event})

    def enter_failsafe_mode(self, mode: CopterMode, sample: VehicleSample) -> None:
        """Switch to ``mode`` (RTL, LAND or BRAKE) from where the vehicle is now."""
        self.mode = mode
        self._hold_enu_m = sample.p_enu_m.copy()
        if MODE_RULES[mode].behaviour is Behaviour.HOLD:
            self.actuators.set_target(
                self.vehicle, position_enu_m=sample.p_enu_m, yaw_rad=sample.psi_rad
            )
            self.target_has_velocity = False
        self._say(m.MavSeverity.INFO, f"Mode {mode.name}")

    def land_here(self, sample: VehicleSample, hold_enu_m: FloatArray | None = None) -> None:
        """One tick of LAND's descent (also AUTO's NAV_LAND), over ``hold_enu_m`` if given."""
        if hold_enu_m is not None:
            self._hold_enu_m = hold_enu_m
        self._land(sample)

    def return_home(self, sample: VehicleSample) -> None:
        """One tick of RTL (also AUTO's NAV_RETURN_TO_LAUNCH)."""
        self._rtl(sample)

    def _land(self, sample: VehicleSample) -> None:
        height = sample.p_enu_m[2] - self.home.home_enu_m[2]
        speed = (
            self.params.get("LAND_SPEED_HIGH") / 100.0
            if height > self.params.get("LAND_ALT_LOW") / 100.0
            else self.params.get("LAND_SPEED") / 100.0
        )
        hold = self._hold_enu_m if self._hold_enu_m is not None else sample.p_enu_m
        self.actuators.set_target(
            self.vehicle,
            position_enu_m=np.array([hold[0], hold[1], sample.p_enu_m[2]]),
            velocity_enu_m_s=np.array([0.0, 0.0, -speed]),
            yaw_rad=sample.psi_rad,
        )

    def _rtl(self, sample: VehicleSample) -> None:
        home = self.home.home_enu_m
        rtl_z = max(home[2] + self.params.get("RTL_ALT") / 100.0, float(sample.p_enu_m[2]))
        offset = home[:2] - sample.p_enu_m[:2]
        distance = float(np.hypot(*offset))
        if distance < 2.0:
            self.mode = CopterMode.LAND
            self._hold_enu_m = np.array([home[0], home[1], sample.p_enu_m[2]])
            self._say(m.MavSeverity.INFO, "RTL: home reached, landing")
            return
        climbing = sample.p_enu_m[2] < rtl_z - 1.0
        target = sample.p_enu_m.copy() if climbing else np.array([home[0], home[1], rtl_z])
        target[2] = rtl_z
        velocity = np.zeros(3)
        if not climbing:
            speed_m_s = self.params.get("RTL_SPEED") / 100.0
            velocity[:2] = offset / distance * min(speed_m_s, distance / 2.0)
        self.actuators.set_target(self.vehicle, position_enu_m=target, velocity_enu_m_s=velocity)


# --- the tables -------------------------------------------------------------------------------

__all__ = [
    "ACCEPTED",
    "ARM_CHECKS",
    "COMMAND_HANDLERS",
    "FORCE_DISARM_MAGIC",
    "MODE_RULES",
    "TAKEOFF_CHECKS",
    "Actuators",
    "Autopilot",
    "AutopilotConfig",
    "Behaviour",
    "CommandContext",
    "FailsafeAction",
    "HomeFrame",
    "Mission",
    "ModeRule",
    "Outcome",
    "TelemetryControl",
    "VehicleSample",
]
