"""The mission as the companion drives it: where the goal is, how the flight stands, which
commands to send, and whether the aircraft is in an emergency.

``Mission`` (mission.py) is the state machine; ``MissionDriver`` feeds it a ``FlightStatus``
built from the autopilot's telemetry and the goal in the autopilot's local NED frame, sends
the commands it asks for, hands it COMMAND_ACKs, and logs its events.

Pad clearance (``pad_clearance_m`` > 0; ``pad_clearance``): the planner driver, which sees the
neighbours and regions, reports what covers the pad (``set_pad_blocker``); the take-off waits
until a check made once the departure is due finds the pad clear, and a landing holds its
height above the delivery point (and does not hand over to LAND) while the point is covered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.companion.autopilot_link import AutopilotWatch
from ridsafe.companion.config import (
    AUTOPILOT_COMPONENT,
    COMPANION_COMPONENT,
    CompanionConfig,
    CompanionSpec,
)
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.mission import FlightStatus, Mission, MissionEvent, Phase
from ridsafe.companion.planner_api import Vec3
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = ["MissionCounters", "MissionDriver"]

_CRITICAL_STATES = frozenset({int(m.MavState.CRITICAL), int(m.MavState.EMERGENCY)})


@dataclass
class MissionCounters:
    acks_unmatched: int = 0


class MissionDriver:
    """Drives ``Mission`` for aircraft ``spec`` (see the module docstring)."""

    def __init__(
        self,
        spec: CompanionSpec,
        config: CompanionConfig,
        own: OwnTelemetry,
        autopilot: AutopilotWatch,
        log: CompanionLog,
    ) -> None:
        self.spec = spec
        self.config = config
        self.own = own
        self.autopilot = autopilot
        self.log = log
        self.mission = Mission(config, spec.sysid, AUTOPILOT_COMPONENT)
        self.counters = MissionCounters()
        self._goal_cache: tuple[frames.GeodeticOrigin, Vec3, Vec3] | None = None
        self._pad_blocker: str | None = None
        self._pad_checked = False  # a check since the departure came due / the descent began

    @property
    def phase(self) -> Phase:
        return self.mission.phase

    def step(self, now_s: float) -> list[m.CommandLong]:
        """The commands to send now."""
        commands = self.mission.step(now_s, self.flight_status(now_s))
        self.log_events(now_s)
        return commands

    def on_ack(self, now_s: float, msg: m.CommandAck) -> None:
        system_ok = msg.target_system in (0, self.spec.sysid)
        for_us = system_ok and msg.target_component in (0, COMPANION_COMPONENT)
        if not (for_us and self.mission.on_ack(now_s, msg)):
            self.counters.acks_unmatched += 1
        self.log_events(now_s)

    def goal_local(self) -> Vec3 | None:
        """The delivery point in the local frame: at cruise altitude, or on the ground (home
        level) once the aircraft descends to deliver."""
        origin, home = self.own.home_origin, self.own.home
        if origin is None or home is None:
            return None
        if self._goal_cache is None or self._goal_cache[0] != origin:
            lat, lon = self.spec.goal_lat_deg, self.spec.goal_lon_deg
            cruise = self.own.to_local(lat, lon, home.alt_msl_m + self.spec.cruise_alt_m)
            ground = self.own.to_local(lat, lon, home.alt_msl_m)
            self._goal_cache = (origin, cruise, ground)
        _, cruise, ground = self._goal_cache
        if self.mission.phase is not Phase.DESCEND:
            return cruise
        lpn = self.own.lpn
        if self._pad_blocker is not None and lpn is not None:
            return (ground[0], ground[1], min(lpn.p_ned_m[2], ground[2]))  # hold the height
        return ground

    def goal_any_height(self) -> bool:
        """``goal_local`` is reached over it at any height: the cruise point before the
        descent, when arriving asks no height (``arrival_alt_tolerance_m`` unset)."""
        return not self.descending() and self.config.arrival_alt_tolerance_m is None

    def descending(self) -> bool:
        """``goal_local`` is the ground under the site, reached by descending over it."""
        return self.mission.phase is Phase.DESCEND

    def pad_ned_m(self) -> Vec3 | None:
        """The pad the mission is about to use: its own (home) before take-off, the delivery
        point on the ground while descending; None in other phases or before home is known."""
        phase = self.mission.phase
        if phase is Phase.WAIT_DEPARTURE and self.own.home is not None:
            return self.own.home.p_ned_m
        if phase is Phase.DESCEND and self._goal_cache is not None:
            return self._goal_cache[2]
        return None

    def set_pad_blocker(self, now_s: float, blocker: str | None) -> None:
        """What covers the pad now (None: clear); logs when that changes."""
        if blocker != self._pad_blocker:
            if blocker is None:
                self.log.event(now_s, "pad_clear", f"{self.mission.phase.value}: pad clear")
            else:
                self.log.event(now_s, "pad_blocked", f"{self.mission.phase.value}: {blocker}")
        self._pad_blocker = blocker
        self._pad_checked = True

    def _pad_clear(self, departure_due: bool) -> bool:
        if self.config.pad_clearance_m <= 0.0:
            return True
        if self.mission.phase is Phase.WAIT_DEPARTURE and not departure_due:
            self._pad_checked = False
        return self._pad_checked and self._pad_blocker is None

    def flight_status(self, now_s: float) -> FlightStatus:
        gpi, lpn, goal = self.own.gpi, self.own.lpn, self.goal_local()
        distance = alt_error = speed = None
        if lpn is not None:
            speed = math.hypot(*lpn.v_ned_m_s)
            if goal is not None:
                p = lpn.p_ned_m
                distance = math.hypot(goal[0] - p[0], goal[1] - p[1])
                alt_error = abs(goal[2] - p[2])
        departure_due = self.own.sim_time(now_s) >= self.spec.departure_s
        return FlightStatus(
            link_up=self.autopilot.link_up(now_s),
            departure_due=departure_due,
            pad_clear=self._pad_clear(departure_due),
            heartbeat_s=self.own.heartbeat_s,
            armed=self.own.armed,
            custom_mode=None if self.own.heartbeat is None else self.own.heartbeat.custom_mode,
            altitude_m=None if gpi is None else gpi.relative_alt_m,
            goal_distance_h_m=distance,
            goal_alt_error_m=alt_error,
            speed_m_s=speed,
        )

    def emergency(self) -> bool:
        """Remote ID EMERGENCY: the mission failed in the air, the autopilot reports a
        critical state, or it went silent while armed."""
        heartbeat = self.own.heartbeat
        critical = heartbeat is not None and heartbeat.system_status in _CRITICAL_STATES
        failed = self.mission.phase is Phase.FAILED
        return self.own.armed and (failed or critical or self.autopilot.lost)

    def log_events(self, now_s: float) -> None:
        for event in self.mission.take_events():
            self._event(now_s, event)

    def _event(self, now_s: float, event: MissionEvent) -> None:
        self.log.event(now_s, event.event, event.detail, **event.fields)
        if event.event == "phase" and event.fields.get("to") == Phase.ARRIVED.value:
            radius = self.config.arrival_radius_m
            self.log.event(now_s, "arrived", f"within {radius:g} m of the goal")
