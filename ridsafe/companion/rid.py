"""The aircraft's own Remote ID broadcast: what goes to the transponder, and when.

Cadence (ArduPilot's Remote ID checks; ``CompanionConfig``): LOCATION every
``rid_location_period_s`` (1 s), SYSTEM_UPDATE every ``rid_system_update_period_s`` (1 s),
BASIC_ID, SYSTEM and OPERATOR_ID every ``rid_static_period_s`` (2.5 s, so each is never older
than ArduPilot's 3 s). Timers are phase-locked (``Periodic``): a late tick skips missed slots
rather than bunching them, so rates stay exact over a run.

Contents are built by :mod:`ridsafe.common.rid` (shared with the simulated spoofer):
LOCATION from the autopilot's own telemetry and time (``rid.OwnState``, built by the
companion), SYSTEM / SYSTEM_UPDATE with the operator (take-off) location, BASIC_ID with the
CTA-2063-A serial. A message whose inputs are not known yet (no position, no UNIX time, no
home) is not sent: its timer starts once they are, and later gaps are counted per missed slot.
SYSTEM_UPDATE waits for the first SYSTEM (a transponder applies it to the last SYSTEM).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ridsafe.common import messages as m
from ridsafe.common import rid
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = ["OperatorLocation", "OwnRidBroadcaster", "Periodic", "RidCounters"]

_EPS_S = 1e-9


class Periodic:
    """Due at the first ``due`` call (or ``start_s``), then every ``period_s``, phase-locked."""

    def __init__(self, period_s: float, start_s: float | None = None) -> None:
        if not (math.isfinite(period_s) and period_s > 0.0):
            raise ValueError(f"period_s must be finite and > 0, got {period_s}")
        self.period_s = period_s
        self.next_s = start_s

    @property
    def started(self) -> bool:
        return self.next_s is not None

    def due(self, now_s: float) -> bool:
        """True once per slot; the first call starts the timer (and is due)."""
        if self.next_s is None:
            self.next_s = now_s
        if now_s < self.next_s - _EPS_S:
            return False
        missed = math.floor((now_s - self.next_s) / self.period_s + _EPS_S)
        self.next_s += (max(missed, 0) + 1) * self.period_s
        return True


@dataclass(frozen=True, slots=True)
class OperatorLocation:
    """Where the operator is: the take-off (home) location, WGS-84."""

    lat_deg: float
    lon_deg: float
    alt_m: float


@dataclass
class RidCounters:
    basic_id: int = 0
    location: int = 0
    system: int = 0
    system_update: int = 0
    operator_id: int = 0
    location_unavailable: int = 0  # LOCATION slots missed: no position or no time
    system_unavailable: int = 0  # SYSTEM / SYSTEM_UPDATE slots missed: no home or no time


class OwnRidBroadcaster:
    """The OPEN_DRONE_ID_* messages one aircraft hands its transponder."""

    def __init__(self, serial: str, operator_id: str, config: CompanionConfig) -> None:
        self.serial = serial
        self.counters = RidCounters()
        self._basic_id = rid.basic_id(serial)
        self._operator_id = rid.operator_id(operator_id)
        self._static = Periodic(config.rid_static_period_s)
        self._system = Periodic(config.rid_static_period_s)
        self._location = Periodic(config.rid_location_period_s)
        self._system_update = Periodic(config.rid_system_update_period_s)
        self._next_due_s = -math.inf  # the slots move in ``due`` alone

    def next_due_s(self) -> float:
        """When the next message is due (-inf before the first call): callers may skip
        building the aircraft's state until then."""
        return self._next_due_s

    def broadcast(
        self, now_s: float, own: OwnTelemetry, emergency: bool, max_extrapolation_s: float
    ) -> list[m.Message]:
        """What is due now, built from the autopilot's telemetry (``emergency``: the
        LOCATION status says EMERGENCY)."""
        if now_s < self.next_due_s():
            return []
        home = own.home
        operator = (
            None if home is None else OperatorLocation(home.lat_deg, home.lon_deg, home.alt_msl_m)
        )
        state = own.rid_state(now_s, emergency, max_extrapolation_s)
        return self.due(now_s, state, operator, own.unix_s(now_s))

    def due(
        self,
        now_s: float,
        own: rid.OwnState | None,
        operator: OperatorLocation | None,
        unix_s: float | None,
    ) -> list[m.Message]:
        """Messages to send now, in the order BASIC_ID, SYSTEM, OPERATOR_ID, LOCATION,
        SYSTEM_UPDATE. ``own``: None while position or time is unknown."""
        static_due = self._static.due(now_s)
        out: list[m.Message] = []
        if static_due:
            out.append(self._basic_id)
            self.counters.basic_id += 1
        out.extend(self._system_message(now_s, operator, unix_s))
        if static_due:
            out.append(self._operator_id)
            self.counters.operator_id += 1
        out.extend(self._location_message(now_s, own))
        out.extend(self._system_update_message(now_s, operator, unix_s))
        slots = (self._static, self._system, self._location, self._system_update)
        self._next_due_s = min(-math.inf if p.next_s is None else p.next_s for p in slots) - _EPS_S
        return out

    def _system_message(
        self, now_s: float, operator: OperatorLocation | None, unix_s: float | None
    ) -> list[m.Message]:
        if operator is None or unix_s is None:
            if self._system.started and self._system.due(now_s):
                self.counters.system_unavailable += 1
            return []
        if not self._system.due(now_s):
            return []
        self.counters.system += 1
        return [rid.system(unix_s, operator.lat_deg, operator.lon_deg, operator.alt_m)]

    def _location_message(self, now_s: float, own: rid.OwnState | None) -> list[m.Message]:
        if own is None:
            if self._location.started and self._location.due(now_s):
                self.counters.location_unavailable += 1
            return []
        if not self._location.due(now_s):
            return []
        self.counters.location += 1
        return [rid.location(own)]

    def _system_update_message(
        self, now_s: float, operator: OperatorLocation | None, unix_s: float | None
    ) -> list[m.Message]:
        if self.counters.system == 0:
            return []
        if operator is None or unix_s is None:
            if self._system_update.due(now_s):
                self.counters.system_unavailable += 1
            return []
        if not self._system_update.due(now_s):
            return []
        self.counters.system_update += 1
        return [rid.system_update(unix_s, operator.lat_deg, operator.lon_deg, operator.alt_m)]
