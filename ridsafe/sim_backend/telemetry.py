"""Autopilot telemetry: which messages a link streams at which rate, and their contents.

``TelemetrySchedule`` is one link's stream table (message id -> interval), changed by
MAV_CMD_SET_MESSAGE_INTERVAL and MAV_CMD_REQUEST_MESSAGE as on ArduPilot. ``FleetSnapshot``
turns the fleet's truth (scenario ENU, body FLU) into what MAVLink reports (WGS-84, each
vehicle's local NED at its home, body FRD), once per tick for all vehicles.

Altitudes: the sim has no geoid, so "MSL" altitudes are WGS-84 ellipsoid heights.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.dialect import ridsafe_v20 as ids
from ridsafe.common.protocol_messages import LandedState
from ridsafe.sim_backend.autopilot import MODE_RULES, Autopilot, Behaviour, HomeFrame
from ridsafe.sim_backend.dynamics import BODY_RATES, EULER, POS_ENU, VEL_ENU

FloatArray = NDArray[np.float64]

HEARTBEAT = ids.MAVLINK_MSG_ID_HEARTBEAT
SYS_STATUS = ids.MAVLINK_MSG_ID_SYS_STATUS
SYSTEM_TIME = ids.MAVLINK_MSG_ID_SYSTEM_TIME
ATTITUDE = ids.MAVLINK_MSG_ID_ATTITUDE
LOCAL_POSITION_NED = ids.MAVLINK_MSG_ID_LOCAL_POSITION_NED
GLOBAL_POSITION_INT = ids.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
HOME_POSITION = ids.MAVLINK_MSG_ID_HOME_POSITION
EXTENDED_SYS_STATE = ids.MAVLINK_MSG_ID_EXTENDED_SYS_STATE
GPS_RAW_INT = ids.MAVLINK_MSG_ID_GPS_RAW_INT
VFR_HUD = ids.MAVLINK_MSG_ID_VFR_HUD
BATTERY_STATUS = ids.MAVLINK_MSG_ID_BATTERY_STATUS
RC_CHANNELS = ids.MAVLINK_MSG_ID_RC_CHANNELS
MISSION_CURRENT = ids.MAVLINK_MSG_ID_MISSION_CURRENT
AUTOPILOT_VERSION = ids.MAVLINK_MSG_ID_AUTOPILOT_VERSION

# Gyro, accel, mag, baro, GPS, motor outputs, AHRS: present, enabled, healthy.
_SENSORS = 0x1 | 0x2 | 0x4 | 0x8 | 0x20 | 0x8000 | 0x200000
_PREARM = 0x10000000  # MAV_SYS_STATUS_PREARM_CHECK: healthy once arming checks pass
_GEOFENCE = 0x100000  # present with FENCE_ENABLE; always healthy unless breached
_BATTERY_V = 25.2  # 6S full; the sim has no battery model


@dataclass(frozen=True)
class TelemetryRatesHz:
    """Default stream rates of every autopilot link (0 = off)."""

    heartbeat: float = 1.0
    global_position_int: float = 10.0
    local_position_ned: float = 10.0
    attitude: float = 4.0
    sys_status: float = 1.0
    system_time: float = 1.0
    home_position: float = 0.5
    # Off unless a client asks (SET_MESSAGE_INTERVAL, REQUEST_DATA_STREAM, SRx_*); "0 = the
    # default rate" in SET_MESSAGE_INTERVAL then means ``ON_REQUEST_HZ``.
    extended_sys_state: float = 0.0
    gps_raw_int: float = 0.0
    vfr_hud: float = 0.0
    battery_status: float = 0.0
    rc_channels: float = 0.0
    mission_current: float = 0.0
    autopilot_version: float = 0.0  # answered to requests only
    # False: like ArduCopter, stream nothing but HEARTBEAT until a client asks; our own apps
    # then ask for what they need. True keeps the sim's convenience: the rates above.
    stream_unasked: bool = True

    def __post_init__(self) -> None:
        for name, value in self.by_id_name():
            if not (math.isfinite(value) and 0.0 <= value <= 400.0):
                raise ValueError(f"{name}: expected 0..400 Hz, got {value}")

    def by_id_name(self) -> list[tuple[str, float]]:
        return [(name, getattr(self, name)) for name in _STREAM_IDS]

    def by_id(self) -> dict[int, float]:
        return {_STREAM_IDS[name]: rate for name, rate in self.by_id_name()}

    def initial_by_id(self) -> dict[int, float]:
        """What a link streams before anyone asks."""
        if self.stream_unasked:
            return self.by_id()
        return {k: (v if k == HEARTBEAT else 0.0) for k, v in self.by_id().items()}


_STREAM_IDS: dict[str, int] = {
    "heartbeat": HEARTBEAT,
    "global_position_int": GLOBAL_POSITION_INT,
    "local_position_ned": LOCAL_POSITION_NED,
    "attitude": ATTITUDE,
    "sys_status": SYS_STATUS,
    "system_time": SYSTEM_TIME,
    "home_position": HOME_POSITION,
    "extended_sys_state": EXTENDED_SYS_STATE,
    "gps_raw_int": GPS_RAW_INT,
    "vfr_hud": VFR_HUD,
    "battery_status": BATTERY_STATUS,
    "rc_channels": RC_CHANNELS,
    "mission_current": MISSION_CURRENT,
    "autopilot_version": AUTOPILOT_VERSION,
}
ON_REQUEST_HZ = 4.0


@dataclass
class TelemetrySchedule:
    """One link's streams: message id -> interval (s, inf = off) and next due time."""

    defaults_hz: dict[int, float]
    initial_hz: dict[int, float] | None = None  # None: the defaults
    interval_s: dict[int, float] = field(init=False)
    next_due_s: dict[int, float] = field(init=False)
    requested: set[int] = field(default_factory=set)
    earliest_s: float = field(init=False, default=0.0)  # no stream is due before this

    def __post_init__(self) -> None:
        initial = self.defaults_hz if self.initial_hz is None else self.initial_hz
        self.interval_s = {k: _interval(initial[k]) for k in self.defaults_hz}
        self.next_due_s = dict.fromkeys(self.defaults_hz, 0.0)

    def _update_earliest(self) -> None:
        due = [t for k, t in self.next_due_s.items() if self.interval_s[k] != math.inf]
        self.earliest_s = min(due, default=math.inf)

    def set_interval(self, msg_id: int, interval_us: float) -> bool:
        """MAV_CMD_SET_MESSAGE_INTERVAL: -1 off, 0 default, else the interval in us."""
        if msg_id not in self.interval_s:
            return False
        if interval_us < 0:
            self.interval_s[msg_id] = math.inf
        elif interval_us == 0:
            self.interval_s[msg_id] = _interval(self.defaults_hz[msg_id] or ON_REQUEST_HZ)
        else:
            self.interval_s[msg_id] = max(interval_us * 1e-6, 0.0025)
            self.next_due_s[msg_id] = 0.0
        self._update_earliest()
        return True

    def request_once(self, msg_id: int) -> bool:
        if msg_id not in self.interval_s:
            return False
        self.requested.add(msg_id)
        return True

    def due(self, now_s: float) -> list[int]:
        """Message ids to send now (each at most once per call), in a fixed order.

        A stream keeps its phase and skips slots it missed instead of bursting; a message
        asked for with ``request_once`` is sent in addition, without moving its stream.
        """
        if now_s < self.earliest_s - 1e-9 and not self.requested:
            return []
        out = []
        for msg_id, interval in self.interval_s.items():
            periodic = interval != math.inf and now_s >= self.next_due_s[msg_id] - 1e-9
            if periodic:
                missed = math.floor((now_s - self.next_due_s[msg_id]) / interval + 1e-9)
                self.next_due_s[msg_id] += (max(missed, 0) + 1) * interval
            if periodic or msg_id in self.requested:
                out.append(msg_id)
        self.requested.clear()
        self._update_earliest()
        return out


def _interval(rate_hz: float) -> float:
    return math.inf if rate_hz <= 0 else 1.0 / rate_hz


class FleetSnapshot:
    """Every vehicle's truth at one tick, converted to what its autopilot reports."""

    def __init__(
        self,
        now_s: float,
        unix_s: float,
        state: FloatArray,
        homes: Sequence[HomeFrame],
        origin: frames.GeodeticOrigin,
        on_ground: NDArray[np.bool_] | None = None,
    ) -> None:
        self.now_s = now_s
        self.on_ground = on_ground
        self.unix_s = unix_s
        self.p_enu_m = state[:, POS_ENU]
        self.v_enu_m_s = state[:, VEL_ENU]
        self.euler_rad = state[:, EULER]
        self.rates_flu_rad_s = state[:, BODY_RATES]
        self.homes = homes
        self._origin = origin

    @functools.cached_property
    def _geodetic(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(lat deg, lon deg, alt m) of every vehicle: converted on first use (a tick whose
        due messages carry no geodetic position converts nothing)."""
        return frames.enu_to_geodetic(self._origin, self.p_enu_m)

    @property
    def lat_deg(self) -> FloatArray:
        return self._geodetic[0]

    @property
    def lon_deg(self) -> FloatArray:
        return self._geodetic[1]

    @property
    def alt_m(self) -> FloatArray:
        return self._geodetic[2]

    def global_position_int(self, i: int) -> m.GlobalPositionInt:
        home = self.homes[i]
        v_ned = home.vel_enu_to_ned(self.v_enu_m_s[i])
        yaw_deg = math.degrees(frames.wrap_pi(math.pi / 2 - float(self.euler_rad[i, 2]))) % 360.0
        return m.GlobalPositionInt(
            self.now_s,
            float(self.lat_deg[i]),
            float(self.lon_deg[i]),
            float(self.alt_m[i]),
            float(self.alt_m[i] - home.home_geodetic.alt_m),
            (float(v_ned[0]), float(v_ned[1]), float(v_ned[2])),
            yaw_deg,
        )

    def local_position_ned(self, i: int) -> m.LocalPositionNed:
        home = self.homes[i]
        p = home.enu_to_local_ned(self.p_enu_m[i])
        v = home.vel_enu_to_ned(self.v_enu_m_s[i])
        return m.LocalPositionNed(
            self.now_s,
            (float(p[0]), float(p[1]), float(p[2])),
            (float(v[0]), float(v[1]), float(v[2])),
        )

    def attitude(self, i: int) -> m.Attitude:
        phi, theta, psi = (float(a) for a in self.euler_rad[i])
        roll, pitch, yaw = frames.attitude_sim_to_mavlink(phi, theta, psi)
        p, q, r = frames.body_rates_flu_to_frd(*(float(w) for w in self.rates_flu_rad_s[i]))
        return m.Attitude(self.now_s, roll, pitch, yaw, (p, q, r))

    def sys_status(
        self, _i: int, prearm_ok: bool = True, fence_on: bool = False, fence_ok: bool = True
    ) -> m.SysStatus:
        """Geofence present and enabled with FENCE_ENABLE, healthy unless breached."""
        fence = _GEOFENCE if fence_on else 0
        health = _SENSORS | (_GEOFENCE if fence_ok else 0) | (_PREARM if prearm_ok else 0)
        present = _SENSORS | _PREARM | fence
        return m.SysStatus(present, present, health, 15.0, _BATTERY_V, 100)

    def system_time(self, _i: int) -> m.SystemTime:
        return m.SystemTime(self.unix_s, self.now_s)

    def home_position(self, i: int) -> m.HomePosition:
        home = self.homes[i].home_geodetic
        return m.HomePosition(home.lat_deg, home.lon_deg, home.alt_m, (0.0, 0.0, 0.0))

    # -- what ground stations expect besides (ArduCopter's values where the sim has none) --

    def landed_state(self, i: int, autopilot: Autopilot) -> int:
        on_ground = self.on_ground is not None and bool(self.on_ground[i])
        if not autopilot.armed or (on_ground and autopilot.takeoff_alt_enu_m is None):
            return LandedState.ON_GROUND
        if autopilot.takeoff_alt_enu_m is not None:
            return LandedState.TAKEOFF
        if MODE_RULES[autopilot.mode].behaviour is Behaviour.LAND:
            return LandedState.LANDING
        return LandedState.IN_AIR

    def extended_sys_state(self, i: int, autopilot: Autopilot) -> pm.ExtendedSysState:
        return pm.ExtendedSysState(0, int(self.landed_state(i, autopilot)))

    def gps_raw_int(self, i: int, autopilot: Autopilot) -> pm.GpsRawInt:
        """A 3D fix with 10 satellites once the pre-arm period is over, none before."""
        fix = autopilot.prearm_ok(self.now_s) or autopilot.params.get("ARMING_CHECK") == 0
        v = self.v_enu_m_s[i]
        course_deg = math.degrees(math.atan2(float(v[0]), float(v[1]))) % 360.0
        return pm.GpsRawInt(
            self.now_s, 3 if fix else 1, float(self.lat_deg[i]), float(self.lon_deg[i]),
            float(self.alt_m[i]), 0.8, 1.2, float(math.hypot(v[0], v[1])), course_deg,
            10 if fix else 4,
        )  # fmt: skip

    def vfr_hud(self, i: int, autopilot: Autopilot) -> pm.VfrHud:
        v = self.v_enu_m_s[i]
        speed = float(math.hypot(v[0], v[1]))
        heading = round(math.degrees(frames.wrap_pi(math.pi / 2 - float(self.euler_rad[i, 2]))))
        throttle = 50 if autopilot.armed else 0
        return pm.VfrHud(speed, speed, heading % 360, throttle, float(self.alt_m[i]), float(v[2]))

    def battery_status(self, _i: int, _autopilot: Autopilot) -> pm.BatteryStatus:
        return pm.BatteryStatus(_BATTERY_V, 0.0, 100)

    def rc_channels(self, _i: int, _autopilot: Autopilot) -> pm.RcChannels:
        """No RC: sticks centred, throttle low (as SITL without a joystick)."""
        channels = (1500, 1500, 1000, 1500) + (1000,) * 12
        return pm.RcChannels(self.now_s, 16, channels, 255)

    def mission_current(self, _i: int, autopilot: Autopilot) -> pm.MissionCurrent:
        store = autopilot.missions
        return pm.MissionCurrent(store.current_seq, store.count(pm.MissionType.MISSION))

    def autopilot_version(self, _i: int, autopilot: Autopilot) -> pm.AutopilotVersion:
        return pm.AutopilotVersion(CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, autopilot.sysid)


# MAV_PROTOCOL_CAPABILITY: MISSION_FLOAT, PARAM_FLOAT, MISSION_INT, COMMAND_INT,
# SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT, MAVLINK2, MISSION_FENCE,
# MISSION_RALLY (what ArduCopter announces, without FTP and parameter-union bits).
CAPABILITIES = 0x1 | 0x2 | 0x4 | 0x8 | 0x80 | 0x100 | 0x2000 | 0x4000 | 0x8000
FLIGHT_SW_VERSION = (4 << 24) | (7 << 16) | (0 << 8) | 0  # 4.7.0, type "dev"

Builder = Callable[[FleetSnapshot, int, "Autopilot"], m.Message]

BUILDERS: dict[int, Builder] = {
    HEARTBEAT: lambda snapshot, i, ap: ap.heartbeat(),
    GLOBAL_POSITION_INT: lambda snapshot, i, ap: snapshot.global_position_int(i),
    LOCAL_POSITION_NED: lambda snapshot, i, ap: snapshot.local_position_ned(i),
    ATTITUDE: lambda snapshot, i, ap: snapshot.attitude(i),
    SYS_STATUS: lambda snapshot, i, ap: snapshot.sys_status(
        i, ap.prearm_ok(snapshot.now_s), ap.fence.enabled(ap), ap.fence.healthy()
    ),
    SYSTEM_TIME: lambda snapshot, i, ap: snapshot.system_time(i),
    HOME_POSITION: lambda snapshot, i, ap: snapshot.home_position(i),
    EXTENDED_SYS_STATE: FleetSnapshot.extended_sys_state,
    GPS_RAW_INT: FleetSnapshot.gps_raw_int,
    VFR_HUD: FleetSnapshot.vfr_hud,
    BATTERY_STATUS: FleetSnapshot.battery_status,
    RC_CHANNELS: FleetSnapshot.rc_channels,
    MISSION_CURRENT: FleetSnapshot.mission_current,
    AUTOPILOT_VERSION: FleetSnapshot.autopilot_version,
}
