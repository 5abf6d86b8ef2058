"""The companion app's configuration (YAML ``companion:``) and the identity of one aircraft.

``CompanionConfig`` is what every companion of a run shares: telemetry rates to ask the
autopilot for, take-off and cruise settings, arrival handling, the periods of the core's
loops (replanning 0.5 s, observation batches 0.25 s, as in the paper), command retries and
the Remote ID cadence ArduPilot's checks expect (LOCATION >= 1 Hz, the static messages at
least every 3 s). ``CompanionSpec`` is what differs per aircraft: system id, serial number,
goal and cruise altitude, operator id.

Units are in the names: ``_s`` seconds (sim time), ``_m`` metres, ``_m_s`` m/s, ``_hz``.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from ridsafe.common import frames
from ridsafe.common.checks import check_in_interval
from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import Scenario, check_cta2063_serial
from ridsafe.companion.traffic_gate import TrafficGate

__all__ = [
    "AUTOPILOT_COMPONENT",
    "COMPANION_COMPONENT",
    "DEFAULT_OPERATOR_ID",
    "MAX_AIRCRAFT_SPEED_M_S",
    "TRANSPONDER_COMPONENT",
    "CompanionConfig",
    "CompanionSpec",
    "OnArrival",
    "StreamRatesHz",
]

#: MAV_COMP_ID_AUTOPILOT1, MAV_COMP_ID_ONBOARD_COMPUTER, MAV_COMP_ID_ODID_TXRX_1.
AUTOPILOT_COMPONENT = 1
COMPANION_COMPONENT = 191
TRANSPONDER_COMPONENT = 236
#: The paper's maximum aircraft speed (NMAC threshold rationale).
MAX_AIRCRAFT_SPEED_M_S = 8.0
#: ArduPilot expects every Remote ID message other than LOCATION at least this often.
RID_STATIC_MAX_PERIOD_S = 3.0
DEFAULT_OPERATOR_ID = "RIDSAFE-OPERATOR-1"

# common.xml message ids of the streams a companion asks for (MAV_CMD_SET_MESSAGE_INTERVAL).
_STREAM_IDS: dict[str, int] = {
    "global_position_int": 33,
    "local_position_ned": 32,
    "system_time": 2,
    "home_position": 242,
    "attitude": 30,
    "sys_status": 1,
}


class OnArrival(enum.Enum):
    """What the mission does once within ``arrival_radius_m`` of the goal."""

    HOVER = "hover"  # hold a position target at the goal
    LAND = "land"  # MAV_CMD_NAV_LAND, wait for the autopilot to disarm


@dataclass(frozen=True)
class StreamRatesHz:
    """Telemetry the companion asks its autopilot for at start: a rate in Hz, 0 to leave the
    stream as it is, -1 to turn it off (what the companion does not read costs the link)."""

    global_position_int: float = 5.0
    local_position_ned: float = 5.0
    system_time: float = 1.0
    home_position: float = 0.5
    attitude: float = -1.0
    sys_status: float = -1.0

    def __post_init__(self) -> None:
        for name in _STREAM_IDS:
            value = getattr(self, name)
            if not (value == -1.0 or (math.isfinite(value) and 0.0 <= value <= 400.0)):
                raise FieldValueError(name, f"expected -1 (off) or 0..400 Hz, got {value}")

    def requests(self) -> tuple[tuple[str, int, float], ...]:
        """(name, message id, interval in us; -1 = off) for every stream not left as it is."""
        return tuple(
            (name, msg_id, -1.0 if rate < 0 else 1e6 / rate)
            for name, msg_id in _STREAM_IDS.items()
            if (rate := getattr(self, name)) != 0.0
        )


@dataclass(frozen=True)
class CompanionConfig:
    """Settings shared by every companion of a run; see the module docstring."""

    streams_hz: StreamRatesHz = field(default_factory=StreamRatesHz)
    # -- flight -----------------------------------------------------------------------------
    takeoff_alt_m: float = 10.0  # MAV_CMD_NAV_TAKEOFF altitude; then climb while cruising
    climb_tolerance_m: float = 1.0  # CLIMB ends within this of the take-off altitude
    cruise_speed_m_s: float = 8.0
    lookahead_s: float = 1.0  # straight-line target this far ahead at cruise speed
    approach_radius_m: float = 15.0  # position-only target at the goal inside this
    arrival_radius_m: float = 10.0  # horizontal
    # Arrived also needs the height within this of the cruise altitude; None (the default):
    # at any height. The delivery is on the ground below, and the descent (flown by the
    # planner among the traffic) starts from wherever the aircraft is: an aircraft that
    # reached its site above or below its cruise level, having avoided traffic there, held
    # the site for its climb or descent to that level first, and others waited on it.
    arrival_alt_tolerance_m: float | None = None
    on_arrival: OnArrival = OnArrival.LAND  # a delivery lands, and leaves the airspace
    # Landing: the planner flies the descent to the delivery point on the ground (still
    # avoiding traffic and unsafe regions); below this height the autopilot's LAND takes over.
    land_handover_alt_m: float = 12.0
    settled_speed_m_s: float = 0.5  # HOVER is DONE below this speed
    # Take-off and landing wait while an unsafe region or another airborne aircraft comes
    # within this of the pad, horizontally (companion/pad_clearance.py); 0 never waits.
    pad_clearance_m: float = 0.0
    pad_lookahead_s: float = 10.0  # a region is projected this far ahead along its velocity
    pad_ceiling_m: float = 30.0  # at take-off, aircraft higher than this over the pad pass
    # Aircraft whose Remote ID puts them on the ground (within 1 m of home level, still) are
    # not handed to the planner as traffic (planner_driver.py); False hands every claim.
    ignore_grounded_traffic: bool = False
    # The same in the descent onto the site only: an aircraft landing among delivery sites
    # tens of metres apart otherwise holds d_safe (100 m) from the aircraft already delivered
    # beside its site, 30-60 m off its own, until the run ends (docs/results/dense_traffic.md).
    landing_ignores_grounded_traffic: bool = True
    # Dense traffic (companion/traffic_gate.py): while at least traffic_gate.min_airborne
    # airborne aircraft are heard, the planner sees only those on a collision course or near;
    # min_airborne 0 (the default) hands every claim.
    traffic_gate: TrafficGate = field(default_factory=TrafficGate)
    # -- loops ------------------------------------------------------------------------------
    replan_period_s: float = 0.5
    observation_batch_s: float = 0.25
    heartbeat_hz: float = 1.0  # own HEARTBEAT on both links
    counters_period_s: float = 10.0
    # -- commands and links -----------------------------------------------------------------
    command_timeout_s: float = 1.0  # resend a COMMAND_LONG with no COMMAND_ACK after this
    command_retries: int = 5  # resends (after a timeout or a rejection) before giving up
    # GUIDED and ARM refused by an autopilot still starting (pre-arm checks): keep retrying
    # for this long after the first attempt (a real ArduCopter needs ~40 s after boot).
    prearm_give_up_s: float = 120.0
    autopilot_timeout_s: float = 3.0  # no autopilot HEARTBEAT for this long: link lost
    gcs_timeout_s: float = 5.0
    # A region the GCS stopped refreshing (validity over, never DELETED: the GCS or its link
    # is lost) is kept this long after its validity, inflated with time (stale_regions.py);
    # 0 drops it when its validity ends.
    stale_region_hold_s: float = 0.0
    stale_region_growth_m2_s: float = 25.0  # covariance growth per second since its estimate
    # -- Remote ID --------------------------------------------------------------------------
    rid_location_period_s: float = 1.0
    rid_system_update_period_s: float = 1.0
    rid_static_period_s: float = 2.5  # BASIC_ID, SYSTEM, OPERATOR_ID
    neighbour_max_age_s: float = 3.0
    max_extrapolation_s: float = 1.0  # own position is extrapolated at most this far
    operator_id: str = DEFAULT_OPERATOR_ID

    def __post_init__(self) -> None:
        check_in_interval("cruise_speed_m_s", self.cruise_speed_m_s, 0.0, MAX_AIRCRAFT_SPEED_M_S)
        check_in_interval("takeoff_alt_m", self.takeoff_alt_m, 1.0, 500.0)
        check_in_interval("rid_location_period_s", self.rid_location_period_s, 0.0, 1.0)
        check_in_interval(
            "rid_static_period_s", self.rid_static_period_s, 0.0, RID_STATIC_MAX_PERIOD_S
        )
        check_in_interval("rid_system_update_period_s", self.rid_system_update_period_s, 0.0, 3.0)
        for name in _POSITIVE:
            check_in_interval(name, getattr(self, name), 0.0, math.inf)
        if (tolerance := self.arrival_alt_tolerance_m) is not None:
            check_in_interval("arrival_alt_tolerance_m", tolerance, 0.0, math.inf)
        if self.approach_radius_m < self.arrival_radius_m:
            raise FieldValueError(
                "approach_radius_m",
                f"expected >= arrival_radius_m ({self.arrival_radius_m}), "
                f"got {self.approach_radius_m}",
            )
        check_in_interval("pad_clearance_m", self.pad_clearance_m, -1e-12, 1000.0)
        check_in_interval("pad_lookahead_s", self.pad_lookahead_s, -1e-12, 120.0)
        check_in_interval("pad_ceiling_m", self.pad_ceiling_m, 0.0, 500.0)
        check_in_interval("stale_region_hold_s", self.stale_region_hold_s, -1e-12, 3600.0)
        check_in_interval("stale_region_growth_m2_s", self.stale_region_growth_m2_s, -1e-12, 1e6)
        if not 0 <= self.command_retries <= 100:
            raise FieldValueError("command_retries", f"expected 0..100, got {self.command_retries}")
        _check_operator_id(self.operator_id)

    @property
    def command_attempts(self) -> int:
        return 1 + self.command_retries


_POSITIVE = (
    "climb_tolerance_m",
    "prearm_give_up_s",
    "lookahead_s",
    "approach_radius_m",
    "arrival_radius_m",
    "settled_speed_m_s",
    "replan_period_s",
    "observation_batch_s",
    "heartbeat_hz",
    "counters_period_s",
    "command_timeout_s",
    "autopilot_timeout_s",
    "gcs_timeout_s",
    "neighbour_max_age_s",
    "max_extrapolation_s",
)


def _check_operator_id(text: str) -> None:
    if not (0 < len(text) <= 20 and text.isascii() and text.isprintable()):
        raise FieldValueError(
            "operator_id", f"expected 1..20 printable ASCII characters, got {text!r}"
        )


@dataclass(frozen=True)
class CompanionSpec:
    """One aircraft: MAVLink system id, CTA-2063-A serial, goal (WGS-84) and cruise altitude
    above home, and the operator id its Remote ID broadcasts."""

    sysid: int
    serial: str
    goal_lat_deg: float
    goal_lon_deg: float
    cruise_alt_m: float
    operator_id: str = DEFAULT_OPERATOR_ID
    departure_s: float = 0.0  # sim time before which it stays on the ground

    def __post_init__(self) -> None:
        if not 0.0 <= self.departure_s <= 86_400.0:
            raise FieldValueError("departure_s", f"expected 0..86400 s, got {self.departure_s}")
        if not 1 <= self.sysid <= 250:
            raise FieldValueError("sysid", f"expected 1..250, got {self.sysid}")
        check_cta2063_serial("serial", self.serial)
        frames.GeodeticOrigin(self.goal_lat_deg, self.goal_lon_deg)  # validates the range
        check_in_interval("cruise_alt_m", self.cruise_alt_m, 0.0, 500.0)
        _check_operator_id(self.operator_id)

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, sysid: int, operator_id: str = DEFAULT_OPERATOR_ID
    ) -> CompanionSpec:
        """Benign aircraft ``sysid`` (1-based) of a scenario."""
        if not 1 <= sysid <= len(scenario.aircraft):
            raise KeyError(f"no benign aircraft {sysid} (have 1..{len(scenario.aircraft)})")
        aircraft = scenario.aircraft[sysid - 1]
        lat, lon, _ = frames.enu_to_geodetic(scenario.origin, np.asarray(aircraft.goal_enu_m))
        return cls(
            sysid,
            aircraft.serial,
            float(lat),
            float(lon),
            aircraft.cruise_alt_m,
            operator_id,
            aircraft.departure_s,
        )
