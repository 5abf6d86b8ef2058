"""The flight-phase state machine of one companion, as tables; sans I/O.

::

    WAIT_HEARTBEAT -> REQUEST_STREAMS -> WAIT_DEPARTURE -> SET_GUIDED -> ARM -> TAKEOFF
        -> CLIMB -> CRUISE -> ARRIVED -> HOVER | DESCEND -> LAND -> DONE
                                                          (any refused step -> FAILED)
    ARM | TAKEOFF -> SET_GUIDED when the autopilot reports a mode other than GUIDED

- ``PHASE_COMMANDS``: the COMMAND_LONGs a phase sends on entry, one at a time (ArduPilot
  answers commands in order and its COMMAND_ACK names only the command id).
- ``PHASE_CONDITIONS``: per phase, (trigger, predicate on ``FlightStatus``) rows, first
  match wins; they are checked before the phase's commands each step.
- ``TRANSITIONS``: (phase, trigger) -> next phase. A pair not in the table changes nothing.

Commands (``CommandQueue``): a command with no COMMAND_ACK within ``command_timeout_s`` is
sent again with ``confirmation`` incremented (as MAVLink's command protocol says); a refused
one (any result but ACCEPTED / IN_PROGRESS) is logged with its MAV_RESULT and retried after
the same delay; after ``1 + command_retries`` attempts a required command fails the mission,
an optional one (the telemetry requests: a real autopilot may not stream everything) is
skipped. While the autopilot link is down nothing is sent and no attempt is used up.

A mode that was accepted may not stay: a real ArduCopter that finishes starting up after
GUIDED was set puts itself back in its initial mode (STABILIZE), where it still arms but
refuses the take-off. So in ARM and TAKEOFF a HEARTBEAT that reports another mode sends the
mission back to SET_GUIDED, at most ``command_attempts`` times per flight (an autopilot that
keeps leaving GUIDED then fails the take-off, and the mission, as before).

The mission reports what happened as ``MissionEvent`` values; the companion logs them.
"""

from __future__ import annotations

import enum
import logging
import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import cast

from ridsafe.common import messages as m
from ridsafe.common.frozen import quick_init
from ridsafe.common.messages import CopterMode, MavCmd, MavModeFlag, MavResult
from ridsafe.companion.config import AUTOPILOT_COMPONENT, CompanionConfig, OnArrival

__all__ = [
    "PHASE_COMMANDS",
    "PHASE_CONDITIONS",
    "TRANSITIONS",
    "CommandQueue",
    "CommandSpec",
    "FlightStatus",
    "Mission",
    "MissionEvent",
    "Phase",
    "Trigger",
    "result_name",
]

logger = logging.getLogger(__name__)

Params7 = tuple[float, float, float, float, float, float, float]


class Phase(enum.Enum):
    WAIT_HEARTBEAT = "wait_heartbeat"
    REQUEST_STREAMS = "request_streams"
    WAIT_DEPARTURE = "wait_departure"
    SET_GUIDED = "set_guided"
    ARM = "arm"
    TAKEOFF = "takeoff"
    CLIMB = "climb"
    CRUISE = "cruise"
    ARRIVED = "arrived"
    DESCEND = "descend"
    HOVER = "hover"
    LAND = "land"
    DONE = "done"
    FAILED = "failed"


class Trigger(enum.Enum):
    HEARTBEAT = "autopilot heartbeat heard"
    DEPARTURE_TIME = "the scheduled departure time has come and the pad is clear"
    COMMANDS_DONE = "the phase's commands are answered"
    COMMANDS_FAILED = "a required command failed after every retry"
    AIRBORNE = "already flying above the take-off altitude"
    CLIMBED = "reached the take-off altitude"
    GOAL_REACHED = "within the arrival radius of the goal"
    HOVER_CHOSEN = "configured to hover on arrival"
    LAND_CHOSEN = "configured to land on arrival"
    SETTLED = "hovering at the goal"
    LOW_ENOUGH = "low enough to hand the landing to the autopilot"
    DISARMED = "the autopilot reports disarmed"
    MODE_LOST = "the autopilot reports a mode other than GUIDED"


@quick_init
@dataclass(frozen=True, slots=True)
class FlightStatus:
    """What the mission needs to know of the vehicle at one step (None: not known yet).

    ``heartbeat_s``: companion time of the latest autopilot HEARTBEAT, ``custom_mode`` the
    ArduCopter mode number it reports; ``altitude_m``: above home; ``goal_*``: horizontal
    distance and |altitude difference| to the goal.
    """

    link_up: bool = False
    heartbeat_s: float | None = None
    armed: bool = False
    altitude_m: float | None = None
    goal_distance_h_m: float | None = None
    goal_alt_error_m: float | None = None
    speed_m_s: float | None = None
    departure_due: bool = True
    pad_clear: bool = True  # nothing covers the take-off / delivery pad (pad_clearance.py)
    custom_mode: int | None = None


@dataclass(frozen=True, slots=True)
class CommandSpec:
    """``patient``: a refusal may be the autopilot still starting (a real ArduCopter refuses
    GUIDED and arming until it has a position estimate, ~40 s): retry past
    ``command_retries`` until ``prearm_give_up_s`` after the first attempt."""

    label: str
    command: MavCmd
    params: Params7
    required: bool = True
    patient: bool = False


@dataclass(frozen=True, slots=True)
class MissionEvent:
    """``event`` is a short name (``phase``, ``command_rejected``...), ``detail`` free text,
    ``fields`` extra values for the log record."""

    event: str
    detail: str
    fields: Mapping[str, object] = field(default_factory=dict)


def result_name(result: int) -> str:
    try:
        return MavResult(result).name
    except ValueError:
        return f"MAV_RESULT_{result}"


def _params(*values: float) -> Params7:
    """Seven COMMAND_LONG parameters: ``values`` then zeros."""
    if len(values) > 7:
        raise ValueError(f"COMMAND_LONG has 7 parameters, got {len(values)}")
    return cast(Params7, tuple(float(v) for v in values) + (0.0,) * (7 - len(values)))


# --- the tables ------------------------------------------------------------------------------


def _stream_commands(config: CompanionConfig) -> tuple[CommandSpec, ...]:
    return tuple(
        CommandSpec(f"stream {name}", MavCmd.SET_MESSAGE_INTERVAL, _params(msg_id, interval), False)
        for name, msg_id, interval in config.streams_hz.requests()
    )


PHASE_COMMANDS: dict[Phase, Callable[[CompanionConfig], tuple[CommandSpec, ...]]] = {
    Phase.REQUEST_STREAMS: _stream_commands,
    Phase.SET_GUIDED: lambda c: (
        CommandSpec(
            "set GUIDED",
            MavCmd.DO_SET_MODE,
            _params(MavModeFlag.CUSTOM_MODE_ENABLED, CopterMode.GUIDED),
            patient=True,
        ),
    ),
    Phase.ARM: lambda c: (
        CommandSpec("arm", MavCmd.COMPONENT_ARM_DISARM, _params(1.0), patient=True),
    ),
    Phase.TAKEOFF: lambda c: (
        CommandSpec("takeoff", MavCmd.NAV_TAKEOFF, _params(0, 0, 0, 0, 0, 0, c.takeoff_alt_m)),
    ),
    Phase.LAND: lambda c: (CommandSpec("land", MavCmd.NAV_LAND, _params()),),
}

# predicate(status, config, phase entry time) -> bool
Condition = Callable[[FlightStatus, CompanionConfig, float], bool]


def _disarmed(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    """A HEARTBEAT heard after entering the phase says disarmed (earlier ones may predate
    the ARM command)."""
    return f.heartbeat_s is not None and f.heartbeat_s > entered_s and not f.armed


def _mode_lost(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    """A HEARTBEAT heard after entering the phase reports a mode other than GUIDED."""
    return (
        f.heartbeat_s is not None
        and f.heartbeat_s > entered_s
        and f.custom_mode is not None
        and f.custom_mode != CopterMode.GUIDED
    )


def _at_takeoff_alt(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    return f.altitude_m is not None and f.altitude_m >= c.takeoff_alt_m - c.climb_tolerance_m


def _airborne(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    return f.armed and _at_takeoff_alt(f, c, entered_s)


def _goal_reached(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    """Over the delivery site: horizontally within ``arrival_radius_m``, at any height unless
    ``arrival_alt_tolerance_m`` asks for the cruise altitude too."""
    if f.goal_distance_h_m is None or f.goal_distance_h_m > c.arrival_radius_m:
        return False
    tolerance = c.arrival_alt_tolerance_m
    return tolerance is None or (f.goal_alt_error_m is not None and f.goal_alt_error_m <= tolerance)


def _low_enough(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    """Low enough to hand the landing over, over the site (horizontally within
    ``arrival_radius_m``: the autopilot's LAND comes straight down, so an aircraft traffic
    pushed off its site in the descent would deliver beside it), and the delivery pad clear
    (held otherwise: the planner brings it back first)."""
    return (
        f.pad_clear
        and f.altitude_m is not None
        and f.altitude_m <= c.land_handover_alt_m
        and f.goal_distance_h_m is not None
        and f.goal_distance_h_m <= c.arrival_radius_m
    )


def _settled(f: FlightStatus, c: CompanionConfig, entered_s: float) -> bool:
    return f.speed_m_s is not None and f.speed_m_s <= c.settled_speed_m_s


PHASE_CONDITIONS: dict[Phase, tuple[tuple[Trigger, Condition], ...]] = {
    Phase.WAIT_HEARTBEAT: ((Trigger.HEARTBEAT, lambda f, c, t: f.heartbeat_s is not None),),
    Phase.WAIT_DEPARTURE: (
        (Trigger.DEPARTURE_TIME, lambda f, c, t: f.departure_due and f.pad_clear),
    ),
    Phase.ARM: ((Trigger.MODE_LOST, _mode_lost),),
    Phase.TAKEOFF: ((Trigger.AIRBORNE, _airborne), (Trigger.MODE_LOST, _mode_lost)),
    Phase.CLIMB: ((Trigger.DISARMED, _disarmed), (Trigger.CLIMBED, _at_takeoff_alt)),
    Phase.CRUISE: ((Trigger.DISARMED, _disarmed), (Trigger.GOAL_REACHED, _goal_reached)),
    Phase.ARRIVED: (
        (Trigger.HOVER_CHOSEN, lambda f, c, t: c.on_arrival is OnArrival.HOVER),
        (Trigger.LAND_CHOSEN, lambda f, c, t: c.on_arrival is OnArrival.LAND),
    ),
    Phase.DESCEND: ((Trigger.DISARMED, _disarmed), (Trigger.LOW_ENOUGH, _low_enough)),
    Phase.HOVER: ((Trigger.DISARMED, _disarmed), (Trigger.SETTLED, _settled)),
    Phase.LAND: ((Trigger.DISARMED, _disarmed),),
}

TRANSITIONS: dict[tuple[Phase, Trigger], Phase] = {
    (Phase.WAIT_HEARTBEAT, Trigger.HEARTBEAT): Phase.REQUEST_STREAMS,
    (Phase.REQUEST_STREAMS, Trigger.COMMANDS_DONE): Phase.WAIT_DEPARTURE,
    (Phase.WAIT_DEPARTURE, Trigger.DEPARTURE_TIME): Phase.SET_GUIDED,
    (Phase.SET_GUIDED, Trigger.COMMANDS_DONE): Phase.ARM,
    (Phase.SET_GUIDED, Trigger.COMMANDS_FAILED): Phase.FAILED,
    (Phase.ARM, Trigger.COMMANDS_DONE): Phase.TAKEOFF,
    (Phase.ARM, Trigger.COMMANDS_FAILED): Phase.FAILED,
    (Phase.ARM, Trigger.MODE_LOST): Phase.SET_GUIDED,
    (Phase.TAKEOFF, Trigger.MODE_LOST): Phase.SET_GUIDED,
    (Phase.TAKEOFF, Trigger.COMMANDS_DONE): Phase.CLIMB,
    (Phase.TAKEOFF, Trigger.AIRBORNE): Phase.CRUISE,  # a companion restarted in flight
    (Phase.TAKEOFF, Trigger.COMMANDS_FAILED): Phase.FAILED,
    (Phase.CLIMB, Trigger.CLIMBED): Phase.CRUISE,
    (Phase.CLIMB, Trigger.DISARMED): Phase.FAILED,
    (Phase.CRUISE, Trigger.GOAL_REACHED): Phase.ARRIVED,
    (Phase.CRUISE, Trigger.DISARMED): Phase.FAILED,
    (Phase.ARRIVED, Trigger.HOVER_CHOSEN): Phase.HOVER,
    (Phase.ARRIVED, Trigger.LAND_CHOSEN): Phase.DESCEND,
    (Phase.DESCEND, Trigger.LOW_ENOUGH): Phase.LAND,
    (Phase.DESCEND, Trigger.DISARMED): Phase.FAILED,
    (Phase.HOVER, Trigger.SETTLED): Phase.DONE,
    (Phase.HOVER, Trigger.DISARMED): Phase.FAILED,
    (Phase.LAND, Trigger.DISARMED): Phase.DONE,
    (Phase.LAND, Trigger.COMMANDS_FAILED): Phase.FAILED,
}


# --- commands ----------------------------------------------------------------------------------


@dataclass
class _Pending:
    spec: CommandSpec
    attempts: int = 0
    awaiting_ack: bool = False
    deadline_s: float = -math.inf  # ACK timeout while awaiting, else earliest next attempt
    first_sent_s: float | None = None
    told_waiting: bool = False


class CommandQueue:
    """A phase's commands, sent one at a time with timeouts, retries and a bound."""

    def __init__(
        self,
        config: CompanionConfig,
        sysid: int,
        emit: Callable[[MissionEvent], None],
        target_component: int = AUTOPILOT_COMPONENT,
    ) -> None:
        self.config = config
        self.sysid = sysid
        self.target_component = target_component
        self._emit = emit
        self._queue: deque[CommandSpec] = deque()
        self._pending: _Pending | None = None
        self._active = False
        self._failed = False

    @property
    def pending(self) -> CommandSpec | None:
        return None if self._pending is None else self._pending.spec

    def load(self, specs: tuple[CommandSpec, ...]) -> None:
        self._queue = deque(specs)
        self._pending = None
        self._active = bool(specs)
        self._failed = False

    def clear(self) -> None:
        self.load(())

    def step(self, now_s: float, link_up: bool) -> tuple[list[m.CommandLong], Trigger | None]:
        """Commands to send now, and COMMANDS_DONE / COMMANDS_FAILED when the list ends."""
        if not self._active:
            return [], None
        if self._pending is None:
            if not self._queue:
                self._active = False
                return [], Trigger.COMMANDS_FAILED if self._failed else Trigger.COMMANDS_DONE
            self._pending = _Pending(self._queue.popleft())
        pending = self._pending
        if not link_up:
            pending.deadline_s = max(pending.deadline_s, now_s + self.config.command_timeout_s)
            return [], None
        if pending.awaiting_ack and now_s >= pending.deadline_s:
            pending.awaiting_ack = False
            self._event("command_timeout", "no COMMAND_ACK", pending)
        if pending.awaiting_ack or now_s < pending.deadline_s:
            return [], None
        if pending.attempts >= self.config.command_attempts and not self._patient(now_s, pending):
            return self._give_up(pending)
        return [self._send(now_s, pending)], None

    def _patient(self, now_s: float, pending: _Pending) -> bool:
        """A patient command refused within ``prearm_give_up_s``: keep trying, say so once."""
        first = pending.first_sent_s
        if not pending.spec.patient or first is None:
            return False
        if now_s - first >= self.config.prearm_give_up_s:
            return False
        if not pending.told_waiting:
            pending.told_waiting = True
            self._event(
                "waiting_prearm",
                "refused: waiting for the autopilot's pre-arm checks (its STATUSTEXT says "
                f"why); retrying until {self.config.prearm_give_up_s:g} s after the first try",
                pending,
            )
        return True

    def _send(self, now_s: float, pending: _Pending) -> m.CommandLong:
        if pending.first_sent_s is None:
            pending.first_sent_s = now_s
        pending.attempts += 1
        pending.awaiting_ack = True
        pending.deadline_s = now_s + self.config.command_timeout_s
        if pending.attempts > 1:
            self._event("command_retry", f"attempt {pending.attempts}", pending)
        spec = pending.spec
        confirmation = min(pending.attempts - 1, 255)
        return m.CommandLong(
            self.sysid, self.target_component, int(spec.command), confirmation, spec.params
        )

    def _give_up(self, pending: _Pending) -> tuple[list[m.CommandLong], Trigger | None]:
        kind = "required" if pending.spec.required else "optional, skipped"
        waited = ""
        if pending.spec.patient and pending.first_sent_s is not None:
            waited = f" over {self.config.prearm_give_up_s:g} s (companion.prearm_give_up_s)"
        self._event(
            "command_failed", f"gave up after {pending.attempts} attempts{waited} ({kind})", pending
        )
        self._pending = None
        if pending.spec.required:
            self._active = False
            self._queue.clear()
            return [], Trigger.COMMANDS_FAILED
        return [], None

    def on_ack(self, now_s: float, ack: m.CommandAck) -> bool:
        """Apply a COMMAND_ACK from the autopilot; False if it answers nothing pending."""
        pending = self._pending
        if pending is None or not pending.awaiting_ack or ack.command != pending.spec.command:
            logger.debug("COMMAND_ACK for %d (result %d) matches nothing", ack.command, ack.result)
            return False
        if ack.result == MavResult.ACCEPTED:
            self._event("command_accepted", "", pending, ack.result)
            self._pending = None
        elif ack.result == MavResult.IN_PROGRESS:
            pending.deadline_s = now_s + self.config.command_timeout_s
        else:
            pending.awaiting_ack = False
            pending.deadline_s = now_s + self.config.command_timeout_s
            name = result_name(ack.result)
            self._event("command_rejected", f"{name} ({ack.result})", pending, ack.result)
            if not pending.spec.required:
                self._pending = None  # a refused telemetry request will not change its mind
        return True

    def _event(self, event: str, detail: str, pending: _Pending, result: int | None = None) -> None:
        spec = pending.spec
        fields: dict[str, object] = {
            "command": int(spec.command),
            "command_name": spec.command.name,
            "label": spec.label,
            "attempt": pending.attempts,
        }
        if result is not None:
            fields["result"] = int(result)
            fields["result_name"] = result_name(result)
        text = f"{spec.label}: {detail}" if detail else spec.label
        self._emit(MissionEvent(event, text, fields))


# --- the mission -------------------------------------------------------------------------------


class Mission:
    """The phase machine of one aircraft; ``step`` once per core tick."""

    def __init__(
        self, config: CompanionConfig, sysid: int, target_component: int = AUTOPILOT_COMPONENT
    ) -> None:
        self.config = config
        self.phase = Phase.WAIT_HEARTBEAT
        self.entered_s = 0.0
        self._events: list[MissionEvent] = []
        self.commands = CommandQueue(config, sysid, self._emit, target_component)
        self.mode_reasserts = 0  # MODE_LOST transitions taken this flight

    def _emit(self, event: MissionEvent) -> None:
        self._events.append(event)

    def take_events(self) -> list[MissionEvent]:
        out, self._events = self._events, []
        return out

    def step(self, now_s: float, status: FlightStatus) -> list[m.CommandLong]:
        """Advance through every transition that applies now; the commands to send."""
        out: list[m.CommandLong] = []
        for _ in range(len(Phase)):  # each pass either changes phase or stops
            trigger = self._condition(status)
            if trigger is None:
                sent, trigger = self.commands.step(now_s, status.link_up)
                out.extend(sent)
            if trigger is None or not self._fire(now_s, trigger):
                break
        return out

    def on_ack(self, now_s: float, ack: m.CommandAck) -> bool:
        return self.commands.on_ack(now_s, ack)

    def _condition(self, status: FlightStatus) -> Trigger | None:
        for trigger, predicate in PHASE_CONDITIONS.get(self.phase, ()):
            if trigger is Trigger.MODE_LOST and self.mode_reasserts >= self.config.command_attempts:
                continue  # bounded: the take-off's own refusal then fails the mission
            if predicate(status, self.config, self.entered_s):
                return trigger
        return None

    def _fire(self, now_s: float, trigger: Trigger) -> bool:
        target = TRANSITIONS.get((self.phase, trigger))
        if target is None:
            logger.debug("%s: %s changes nothing", self.phase.name, trigger.name)
            return False
        self._events.append(
            MissionEvent(
                "phase",
                f"{self.phase.name} -> {target.name}: {trigger.value}",
                {"from": self.phase.value, "to": target.value, "trigger": trigger.name},
            )
        )
        if trigger is Trigger.MODE_LOST:
            self.mode_reasserts += 1
        self.phase = target
        self.entered_s = now_s
        self.commands.load(PHASE_COMMANDS[target](self.config) if target in PHASE_COMMANDS else ())
        return True
