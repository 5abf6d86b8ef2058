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

from ridsafe.common import codec, f3411, frames
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError, WireError
from ridsafe.common.frozen import quick_init

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


# --- receiving -----------------------------------------------------------------------------

MESSAGE_PACK_NAME = f3411.MessageType.MESSAGE_PACK.mavlink_name


@quick_init
@dataclass(frozen=True)
class PackContents:
    """The messages read from a message pack, and why the others could not be read."""

    messages: tuple[m.Message, ...]
    errors: tuple[str, ...] = ()


def messages_in_pack(pack: m.OdidRaw, only: f3411.MessageType | None = None) -> PackContents:
    """The messages inside a received OPEN_DRONE_ID_MESSAGE_PACK (those of type ``only``, if
    given), each with the pack's ``id_or_mac``. A message that does not decode is skipped
    and named in ``errors`` (the others still count); a malformed pack raises RidsafeError."""
    if pack.name != MESSAGE_PACK_NAME:
        raise WireError(f"expected {MESSAGE_PACK_NAME}, got {pack.name}")
    fields = dict(pack.fields)
    size, count = int(str(fields["single_message_size"])), int(str(fields["msg_pack_size"]))
    if size != f3411.MESSAGE_SIZE:
        raise WireError(f"message pack of {size}-byte messages, expected {f3411.MESSAGE_SIZE}")
    body = _octets(fields["messages"])[: count * size]
    id_or_mac = list(_octets(fields["id_or_mac"]))
    messages: list[m.Message] = []
    errors: list[str] = []
    for index in range(len(body) // size):
        part = body[index * size : (index + 1) * size]
        try:
            if only is not None and f3411.message_type(part) is not only:
                continue
            name, values = f3411.decode(part)
            messages.append(codec.message_from_fields(name, dict(values, id_or_mac=id_or_mac)))
        except (RidsafeError, ValueError, TypeError) as exc:
            errors.append(f"message {index}: {exc}")
    return PackContents(tuple(messages), tuple(errors))


def location_in_pack(pack: m.OdidRaw) -> PackContents:
    """The LOCATIONs inside a received message pack (at most one in a valid pack)."""
    return messages_in_pack(pack, f3411.MessageType.LOCATION)


def _octets(value: object) -> bytes:
    if isinstance(value, bytes | bytearray | list | tuple):
        try:
            return bytes(value)
        except (TypeError, ValueError) as exc:
            raise WireError(f"expected bytes: {exc}") from exc
    raise WireError(f"expected bytes, got {type(value).__name__}")
