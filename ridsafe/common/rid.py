"""Building an aircraft's own Remote ID broadcast (OPEN_DRONE_ID_* domain messages).

Shared by every broadcaster (a benign aircraft's companion, the simulated spoofer) so all of
them fill the messages the same way. Time conventions (ASTM F3411 / MAVLink):
LOCATION.timestamp is seconds after the full UTC hour; SYSTEM.timestamp is seconds since
2019-01-01T00:00:00Z.

Broadcast cadence that ArduPilot's Remote ID checks expect: LOCATION at >= 1 Hz, every other
message at least every 3 s (``RID_RATES_HZ``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ridsafe.common import frames
from ridsafe.common import messages as m

ODID_EPOCH_UNIX_S = 1_546_300_800  # 2019-01-01T00:00:00Z
RID_LOCATION_PERIOD_S = 1.0
RID_STATIC_PERIOD_S = 3.0

# Accuracy enums (MAV_ODID_HOR_ACC / VER_ACC / SPEED_ACC / TIME_ACC) a GNSS-fed broadcast
# reports: < 3 m horizontal, < 3 m vertical, < 0.3 m/s speed, 0.1 s time.
HOR_ACC_3M = 11
VER_ACC_3M = 5
SPEED_ACC_03 = 4
TIME_ACC_01S = 1


def seconds_after_hour(unix_s: float) -> float:
    return math.fmod(unix_s, 3600.0)


def odid_system_timestamp(unix_s: float) -> int:
    return max(0, int(unix_s - ODID_EPOCH_UNIX_S))


def id_bytes(serial: str) -> bytes:
    """The 20-byte id field of a serial number (ASCII, NUL padding left to the codec)."""
    raw = serial.encode("ascii")
    if len(raw) > 20:
        raise ValueError(f"serial {serial!r} is longer than 20 characters")
    return raw


@dataclass(frozen=True, slots=True)
class OwnState:
    """What a broadcaster knows of itself at one instant (WGS-84, NED velocity)."""

    unix_s: float
    lat_deg: float
    lon_deg: float
    alt_geodetic_m: float
    height_m: float  # above the take-off point
    v_ned_m_s: m.Vec3
    airborne: bool
    emergency: bool = False


def location(state: OwnState, id_or_mac: bytes = b"") -> m.OdidLocation:
    vn, ve, vd = state.v_ned_m_s
    speed_h = math.hypot(vn, ve)
    course_deg = float(frames.course_deg_from_velocity_ned(state.v_ned_m_s))
    course = None if math.isnan(course_deg) else course_deg
    if state.emergency:
        status = m.OdidStatus.EMERGENCY
    else:
        status = m.OdidStatus.AIRBORNE if state.airborne else m.OdidStatus.GROUND
    return m.OdidLocation(
        id_or_mac=id_or_mac,
        status=int(status),
        course_deg=course,
        speed_horizontal_m_s=speed_h,
        speed_vertical_m_s=-vd,
        lat_deg=state.lat_deg,
        lon_deg=state.lon_deg,
        alt_baro_m=None,
        alt_geodetic_m=state.alt_geodetic_m,
        height_reference=0,  # above take-off
        height_m=state.height_m,
        horizontal_accuracy=HOR_ACC_3M,
        vertical_accuracy=VER_ACC_3M,
        barometer_accuracy=0,
        speed_accuracy=SPEED_ACC_03,
        timestamp_s=round(seconds_after_hour(state.unix_s), 1),
        timestamp_accuracy=TIME_ACC_01S,
    )


def basic_id(serial: str) -> m.OdidBasicId:
    return m.OdidBasicId(
        id_or_mac=b"",
        id_type=int(m.OdidIdType.SERIAL_NUMBER),
        ua_type=int(m.OdidUaType.HELICOPTER_OR_MULTIROTOR),
        uas_id=id_bytes(serial),
    )


def system(
    unix_s: float, operator_lat_deg: float, operator_lon_deg: float, operator_alt_m: float
) -> m.OdidSystem:
    return m.OdidSystem(
        id_or_mac=b"",
        operator_location_type=0,  # take-off location
        classification_type=0,
        operator_lat_deg=operator_lat_deg,
        operator_lon_deg=operator_lon_deg,
        area_count=1,
        area_radius_m=0,
        area_ceiling_m=None,
        area_floor_m=None,
        category_eu=0,
        class_eu=0,
        operator_alt_geo_m=operator_alt_m,
        timestamp_s=odid_system_timestamp(unix_s),
    )


def system_update(
    unix_s: float, operator_lat_deg: float, operator_lon_deg: float, operator_alt_m: float
) -> m.OdidSystemUpdate:
    return m.OdidSystemUpdate(
        operator_lat_deg, operator_lon_deg, operator_alt_m, odid_system_timestamp(unix_s)
    )


def operator_id(operator: str) -> m.OdidOperatorId:
    return m.OdidOperatorId(id_or_mac=b"", operator_id_type=0, operator_id=operator)
