"""The MAVLink codec: domain messages <-> MAVLink 2 bytes. The only module that knows scales.

``MavlinkLink`` is one end of one MAVLink link, sans I/O: ``pack(message) -> bytes`` and
``feed(bytes) -> list[Received]``. It numbers outgoing packets, signs them when a key is
configured, and never raises on bad input: malformed frames, unknown message ids, values
out of range and unsigned or wrongly signed packets are logged, counted in
``LinkCounters`` and dropped, and parsing goes on with the next frame.

Scales (common.xml): lat/lon degE7, altitudes mm (GLOBAL_POSITION_INT, HOME_POSITION),
velocities cm/s, headings cdeg, times ms/us. Open Drone ID "unknown" sentinels map to None.
"""

from __future__ import annotations

import binascii
import collections
import functools
import hashlib
import inspect
import logging
import math
import operator
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError
from ridsafe.common.frozen import quick_init

logger = logging.getLogger(__name__)

DEG_E7 = 1e7
ODID_UNKNOWN_DIRECTION_CDEG = 36100
ODID_UNKNOWN_SPEED_H_CMS = 25500
ODID_UNKNOWN_SPEED_V_CMS = 6300
ODID_UNKNOWN_ALT_M = -1000.0
ODID_UNKNOWN_TIMESTAMP_S = 0xFFFF
ODID_ID_LEN = 20
# Signing timestamps count 10 us units since 2015-01-01T00:00:00Z.
SIGNING_EPOCH_UNIX_S = 1420070400


@quick_init
@dataclass(frozen=True, slots=True)
class Received:
    """One accepted MAVLink message."""

    src_system: int
    src_component: int
    message: m.Message
    signed: bool


@dataclass
class LinkCounters:
    """What a link accepted and what it dropped, by reason."""

    accepted: int = 0
    bad_data: int = 0
    truncated: int = 0
    unknown_id: int = 0
    unhandled: int = 0
    invalid_value: int = 0
    rejected_signature: int = 0
    last_error: str = ""

    @property
    def dropped(self) -> int:
        return (
            self.bad_data
            + self.truncated
            + self.unknown_id
            + self.invalid_value
            + self.rejected_signature
        )


@dataclass(frozen=True)
class SigningConfig:
    """MAVLink 2 signing: 32-byte secret key and the first outgoing timestamp."""

    key: bytes = field(repr=False)
    initial_timestamp: int = 0
    link_id: int = 0

    def __post_init__(self) -> None:
        if len(self.key) != 32:
            raise ValueError(f"signing key must be 32 bytes, got {len(self.key)}")


def signing_timestamp_from_unix(unix_s: float) -> int:
    """MAVLink signing timestamp (10 us units since 2015) for a UNIX time."""
    return max(0, int((unix_s - SIGNING_EPOCH_UNIX_S) * 100_000))


def load_signing_key(path: str | Path) -> bytes:
    """Read a signing key file: 64 hex characters, or a passphrase hashed with SHA-256
    (the convention MAVProxy's ``signing setup`` uses)."""
    text = Path(path).read_text(encoding="utf-8").strip()
    if not text:
        raise WireError(f"{path}: signing key file is empty")
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) == 32:
        return key
    return hashlib.sha256(text.encode("utf-8")).digest()


# --- small conversion helpers -----------------------------------------------------------


def _id20(raw: bytes) -> list[int]:
    if len(raw) > ODID_ID_LEN:
        raise WireError(f"id is {len(raw)} bytes, at most {ODID_ID_LEN} fit")
    return list(raw.ljust(ODID_ID_LEN, b"\x00"))


def _bytes(values: Any) -> bytes:
    """A decoded uint8[20] id field as bytes without its NUL padding."""
    raw = values.encode("latin-1") if isinstance(values, str) else bytes(values)
    return raw.rstrip(b"\x00")


def _check_lat_lon(lat_deg: float, lon_deg: float, what: str) -> None:
    if not (abs(lat_deg) <= 90.0 and abs(lon_deg) <= 180.0):
        raise WireError(f"{what}: latitude {lat_deg} / longitude {lon_deg} out of range")


def _finite(what: str, *values: float) -> None:
    for value in values:
        if not math.isfinite(value):
            raise WireError(f"{what}: non-finite value {value}")


def _deg_e7(value_deg: float) -> int:
    return round(value_deg * DEG_E7)


def _or(value: float | None, unknown: float) -> float:
    return unknown if value is None else value


def _known(value: float, unknown: float) -> float | None:
    return None if value == unknown else value


def _vec(a: float, b: float, c: float) -> m.Vec3:
    return (float(a), float(b), float(c))


# --- standard messages ---------------------------------------------------------------------


class _Wire(NamedTuple):
    """A message on its way out: its pymavlink class and that class's constructor arguments
    (the fields in XML order, MAVLink units). Packed straight into bytes on the hot path
    (:func:`_payload`); made into a pymavlink object only when asked (:func:`to_mavlink`)."""

    cls: Any
    args: tuple[Any, ...]


def _wire(cls: Any, *args: Any) -> _Wire:
    return _Wire(cls, args)


ToMav = Callable[[Any], _Wire]
FromMav = Callable[[Any], m.Message]


def _heartbeat_to(msg: m.Heartbeat) -> _Wire:
    return _wire(
        mav.MAVLink_heartbeat_message,
        msg.mav_type,
        msg.autopilot,
        msg.base_mode,
        msg.custom_mode,
        msg.system_status,
        3,
    )


def _heartbeat_from(raw: Any) -> m.Heartbeat:
    return m.Heartbeat(raw.type, raw.autopilot, raw.base_mode, raw.custom_mode, raw.system_status)


def _command_long_to(msg: m.CommandLong) -> _Wire:
    return _wire(
        mav.MAVLink_command_long_message,
        msg.target_system,
        msg.target_component,
        msg.command,
        msg.confirmation,
        *msg.params,
    )


def _command_long_from(raw: Any) -> m.CommandLong:
    params = (raw.param1, raw.param2, raw.param3, raw.param4, raw.param5, raw.param6, raw.param7)
    return m.CommandLong(
        raw.target_system, raw.target_component, raw.command, raw.confirmation, params
    )


def _command_ack_to(msg: m.CommandAck) -> _Wire:
    return _wire(
        mav.MAVLink_command_ack_message,
        msg.command,
        msg.result,
        msg.progress,
        msg.result_param2,
        msg.target_system,
        msg.target_component,
    )


def _command_ack_from(raw: Any) -> m.CommandAck:
    return m.CommandAck(
        raw.command,
        raw.result,
        raw.target_system,
        raw.target_component,
        raw.progress,
        raw.result_param2,
    )


def _set_mode_to(msg: m.SetMode) -> _Wire:
    return _wire(mav.MAVLink_set_mode_message, msg.target_system, msg.base_mode, msg.custom_mode)


def _set_mode_from(raw: Any) -> m.SetMode:
    return m.SetMode(raw.target_system, raw.base_mode, raw.custom_mode)


def _ms(t_s: float) -> int:
    return round(t_s * 1000.0) & 0xFFFFFFFF


def _spt_to(msg: m.SetPositionTargetLocalNed) -> _Wire:
    return _wire(
        mav.MAVLink_set_position_target_local_ned_message,
        _ms(msg.time_boot_s),
        msg.target_system,
        msg.target_component,
        msg.coordinate_frame,
        msg.type_mask,
        *msg.p_ned_m,
        *msg.v_ned_m_s,
        *msg.a_ned_m_s2,
        msg.yaw_rad,
        msg.yaw_rate_rad_s,
    )


def _spt_from(raw: Any) -> m.SetPositionTargetLocalNed:
    return m.SetPositionTargetLocalNed(
        raw.time_boot_ms / 1000.0,
        raw.target_system,
        raw.target_component,
        raw.coordinate_frame,
        raw.type_mask,
        _vec(raw.x, raw.y, raw.z),
        _vec(raw.vx, raw.vy, raw.vz),
        _vec(raw.afx, raw.afy, raw.afz),
        raw.yaw,
        raw.yaw_rate,
    )


def _cms(v_m_s: float) -> int:
    return max(-32768, min(32767, round(v_m_s * 100.0)))


def _gpi_to(msg: m.GlobalPositionInt) -> _Wire:
    hdg = 65535 if msg.heading_deg is None else round(msg.heading_deg * 100.0) % 36000
    return _wire(
        mav.MAVLink_global_position_int_message,
        _ms(msg.time_boot_s),
        _deg_e7(msg.lat_deg),
        _deg_e7(msg.lon_deg),
        round(msg.alt_msl_m * 1000.0),
        round(msg.relative_alt_m * 1000.0),
        *(_cms(v) for v in msg.v_ned_m_s),
        hdg,
    )


def _gpi_from(raw: Any) -> m.GlobalPositionInt:
    lat, lon = raw.lat / DEG_E7, raw.lon / DEG_E7
    _check_lat_lon(lat, lon, "GLOBAL_POSITION_INT")
    return m.GlobalPositionInt(
        raw.time_boot_ms / 1000.0,
        lat,
        lon,
        raw.alt / 1000.0,
        raw.relative_alt / 1000.0,
        _vec(raw.vx / 100.0, raw.vy / 100.0, raw.vz / 100.0),
        None if raw.hdg == 65535 else raw.hdg / 100.0,
    )


def _lpn_to(msg: m.LocalPositionNed) -> _Wire:
    return _wire(
        mav.MAVLink_local_position_ned_message, _ms(msg.time_boot_s), *msg.p_ned_m, *msg.v_ned_m_s
    )


def _lpn_from(raw: Any) -> m.LocalPositionNed:
    _finite("LOCAL_POSITION_NED", raw.x, raw.y, raw.z, raw.vx, raw.vy, raw.vz)
    return m.LocalPositionNed(
        raw.time_boot_ms / 1000.0, _vec(raw.x, raw.y, raw.z), _vec(raw.vx, raw.vy, raw.vz)
    )


def _attitude_to(msg: m.Attitude) -> _Wire:
    return _wire(
        mav.MAVLink_attitude_message,
        _ms(msg.time_boot_s),
        msg.roll_rad,
        msg.pitch_rad,
        msg.yaw_rad,
        *msg.rates_frd_rad_s,
    )


def _attitude_from(raw: Any) -> m.Attitude:
    _finite("ATTITUDE", raw.roll, raw.pitch, raw.yaw)
    return m.Attitude(
        raw.time_boot_ms / 1000.0,
        raw.roll,
        raw.pitch,
        raw.yaw,
        _vec(raw.rollspeed, raw.pitchspeed, raw.yawspeed),
    )


def _sys_status_to(msg: m.SysStatus) -> _Wire:
    volt_mv = 65535 if msg.battery_voltage_v is None else round(msg.battery_voltage_v * 1e3)
    remaining = -1 if msg.battery_remaining_pct is None else msg.battery_remaining_pct
    return _wire(
        mav.MAVLink_sys_status_message,
        msg.sensors_present,
        msg.sensors_enabled,
        msg.sensors_health,
        round(msg.load_pct * 10.0),
        volt_mv,
        -1,
        remaining,
        0,
        0,
        0,
        0,
        0,
        0,
    )


def _sys_status_from(raw: Any) -> m.SysStatus:
    return m.SysStatus(
        raw.onboard_control_sensors_present,
        raw.onboard_control_sensors_enabled,
        raw.onboard_control_sensors_health,
        raw.load / 10.0,
        None if raw.voltage_battery == 65535 else raw.voltage_battery / 1e3,
        None if raw.battery_remaining < 0 else raw.battery_remaining,
    )


def _home_to(msg: m.HomePosition) -> _Wire:
    return _wire(
        mav.MAVLink_home_position_message,
        _deg_e7(msg.lat_deg),
        _deg_e7(msg.lon_deg),
        round(msg.alt_msl_m * 1000.0),
        *msg.p_ned_m,
        [1.0, 0.0, 0.0, 0.0],
        0.0,
        0.0,
        0.0,
        0,
    )


def _home_from(raw: Any) -> m.HomePosition:
    lat, lon = raw.latitude / DEG_E7, raw.longitude / DEG_E7
    _check_lat_lon(lat, lon, "HOME_POSITION")
    return m.HomePosition(lat, lon, raw.altitude / 1000.0, _vec(raw.x, raw.y, raw.z))


def _system_time_to(msg: m.SystemTime) -> _Wire:
    return _wire(
        mav.MAVLink_system_time_message, round(msg.time_unix_s * 1e6), _ms(msg.time_boot_s)
    )


def _system_time_from(raw: Any) -> m.SystemTime:
    return m.SystemTime(raw.time_unix_usec / 1e6, raw.time_boot_ms / 1000.0)


def _statustext_to(msg: m.StatusText) -> _Wire:
    return _wire(
        mav.MAVLink_statustext_message, msg.severity, msg.text.encode("ascii", "replace")[:50]
    )


def _statustext_from(raw: Any) -> m.StatusText:
    text = raw.text if isinstance(raw.text, str) else bytes(raw.text).decode("ascii", "replace")
    return m.StatusText(raw.severity, text)


# --- Open Drone ID ---------------------------------------------------------------------------


def _odid_location_to(msg: m.OdidLocation) -> _Wire:
    direction = (
        ODID_UNKNOWN_DIRECTION_CDEG
        if msg.course_deg is None
        else round(msg.course_deg * 100.0) % 36000
    )
    speed_h = (
        ODID_UNKNOWN_SPEED_H_CMS
        if msg.speed_horizontal_m_s is None
        else min(25425, max(0, round(msg.speed_horizontal_m_s * 100.0)))
    )
    speed_v = (
        ODID_UNKNOWN_SPEED_V_CMS
        if msg.speed_vertical_m_s is None
        else min(6200, max(-6200, round(msg.speed_vertical_m_s * 100.0)))
    )
    known = msg.lat_deg is not None and msg.lon_deg is not None
    return _wire(
        mav.MAVLink_open_drone_id_location_message,
        0,
        0,
        _id20(msg.id_or_mac),
        msg.status,
        direction,
        speed_h,
        speed_v,
        _deg_e7(msg.lat_deg) if known and msg.lat_deg is not None else 0,
        _deg_e7(msg.lon_deg) if known and msg.lon_deg is not None else 0,
        _or(msg.alt_baro_m, ODID_UNKNOWN_ALT_M),
        _or(msg.alt_geodetic_m, ODID_UNKNOWN_ALT_M),
        msg.height_reference,
        _or(msg.height_m, ODID_UNKNOWN_ALT_M),
        msg.horizontal_accuracy,
        msg.vertical_accuracy,
        msg.barometer_accuracy,
        msg.speed_accuracy,
        _or(msg.timestamp_s, ODID_UNKNOWN_TIMESTAMP_S),
        msg.timestamp_accuracy,
    )


def _odid_location_from(raw: Any) -> m.OdidLocation:
    known = not (raw.latitude == 0 and raw.longitude == 0)
    lat, lon = raw.latitude / DEG_E7, raw.longitude / DEG_E7
    if known:
        _check_lat_lon(lat, lon, "OPEN_DRONE_ID_LOCATION")
    _finite("OPEN_DRONE_ID_LOCATION", raw.altitude_geodetic, raw.altitude_barometric, raw.height)
    return m.OdidLocation(
        id_or_mac=_bytes(raw.id_or_mac),
        status=raw.status,
        course_deg=None if raw.direction > 35999 else raw.direction / 100.0,
        speed_horizontal_m_s=None
        if raw.speed_horizontal == ODID_UNKNOWN_SPEED_H_CMS
        else raw.speed_horizontal / 100.0,
        speed_vertical_m_s=None
        if raw.speed_vertical == ODID_UNKNOWN_SPEED_V_CMS
        else raw.speed_vertical / 100.0,
        lat_deg=lat if known else None,
        lon_deg=lon if known else None,
        alt_baro_m=_known(raw.altitude_barometric, ODID_UNKNOWN_ALT_M),
        alt_geodetic_m=_known(raw.altitude_geodetic, ODID_UNKNOWN_ALT_M),
        height_reference=raw.height_reference,
        height_m=_known(raw.height, ODID_UNKNOWN_ALT_M),
        horizontal_accuracy=raw.horizontal_accuracy,
        vertical_accuracy=raw.vertical_accuracy,
        barometer_accuracy=raw.barometer_accuracy,
        speed_accuracy=raw.speed_accuracy,
        timestamp_s=_known(raw.timestamp, ODID_UNKNOWN_TIMESTAMP_S),
        timestamp_accuracy=raw.timestamp_accuracy,
    )


def _odid_basic_id_to(msg: m.OdidBasicId) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_basic_id_message,
        0,
        0,
        _id20(msg.id_or_mac),
        msg.id_type,
        msg.ua_type,
        _id20(msg.uas_id),
    )


def _odid_basic_id_from(raw: Any) -> m.OdidBasicId:
    return m.OdidBasicId(_bytes(raw.id_or_mac), raw.id_type, raw.ua_type, _bytes(raw.uas_id))


def _opt_latlon(value_e7: int, other_e7: int) -> float | None:
    return None if value_e7 == 0 and other_e7 == 0 else value_e7 / DEG_E7


def _odid_system_to(msg: m.OdidSystem) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_system_message,
        0,
        0,
        _id20(msg.id_or_mac),
        msg.operator_location_type,
        msg.classification_type,
        0 if msg.operator_lat_deg is None else _deg_e7(msg.operator_lat_deg),
        0 if msg.operator_lon_deg is None else _deg_e7(msg.operator_lon_deg),
        msg.area_count,
        msg.area_radius_m,
        _or(msg.area_ceiling_m, ODID_UNKNOWN_ALT_M),
        _or(msg.area_floor_m, ODID_UNKNOWN_ALT_M),
        msg.category_eu,
        msg.class_eu,
        _or(msg.operator_alt_geo_m, ODID_UNKNOWN_ALT_M),
        msg.timestamp_s,
    )


def _odid_system_from(raw: Any) -> m.OdidSystem:
    lat = _opt_latlon(raw.operator_latitude, raw.operator_longitude)
    lon = _opt_latlon(raw.operator_longitude, raw.operator_latitude)
    if lat is not None and lon is not None:
        _check_lat_lon(lat, lon, "OPEN_DRONE_ID_SYSTEM")
    return m.OdidSystem(
        _bytes(raw.id_or_mac),
        raw.operator_location_type,
        raw.classification_type,
        lat,
        lon,
        raw.area_count,
        raw.area_radius,
        _known(raw.area_ceiling, ODID_UNKNOWN_ALT_M),
        _known(raw.area_floor, ODID_UNKNOWN_ALT_M),
        raw.category_eu,
        raw.class_eu,
        _known(raw.operator_altitude_geo, ODID_UNKNOWN_ALT_M),
        raw.timestamp,
    )


def _odid_system_update_to(msg: m.OdidSystemUpdate) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_system_update_message,
        0,
        0,
        0 if msg.operator_lat_deg is None else _deg_e7(msg.operator_lat_deg),
        0 if msg.operator_lon_deg is None else _deg_e7(msg.operator_lon_deg),
        _or(msg.operator_alt_geo_m, ODID_UNKNOWN_ALT_M),
        msg.timestamp_s,
    )


def _odid_system_update_from(raw: Any) -> m.OdidSystemUpdate:
    return m.OdidSystemUpdate(
        _opt_latlon(raw.operator_latitude, raw.operator_longitude),
        _opt_latlon(raw.operator_longitude, raw.operator_latitude),
        _known(raw.operator_altitude_geo, ODID_UNKNOWN_ALT_M),
        raw.timestamp,
    )


def _odid_operator_id_to(msg: m.OdidOperatorId) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_operator_id_message,
        0,
        0,
        _id20(msg.id_or_mac),
        msg.operator_id_type,
        msg.operator_id.encode("ascii")[:20],
    )


def _odid_operator_id_from(raw: Any) -> m.OdidOperatorId:
    return m.OdidOperatorId(_bytes(raw.id_or_mac), raw.operator_id_type, _text(raw.operator_id))


def _odid_self_id_to(msg: m.OdidSelfId) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_self_id_message,
        0,
        0,
        _id20(msg.id_or_mac),
        msg.description_type,
        msg.description.encode("ascii")[:23],
    )


def _odid_self_id_from(raw: Any) -> m.OdidSelfId:
    return m.OdidSelfId(_bytes(raw.id_or_mac), raw.description_type, _text(raw.description))


def _odid_arm_status_to(msg: m.OdidArmStatus) -> _Wire:
    return _wire(
        mav.MAVLink_open_drone_id_arm_status_message, msg.status, msg.error.encode("ascii")[:50]
    )


def _odid_arm_status_from(raw: Any) -> m.OdidArmStatus:
    return m.OdidArmStatus(raw.status, _text(raw.error))


def _text(value: bytes | str) -> str:
    return value if isinstance(value, str) else value.rstrip(b"\x00").decode("ascii", "replace")


_RAW_ODID_NAMES = ("OPEN_DRONE_ID_AUTHENTICATION", "OPEN_DRONE_ID_MESSAGE_PACK")


def _odid_raw_to(msg: m.OdidRaw) -> _Wire:
    if msg.name not in _RAW_ODID_NAMES:
        raise WireError(f"OdidRaw carries {msg.name}, expected one of {_RAW_ODID_NAMES}")
    cls = mav.mavlink_map[getattr(mav, "MAVLINK_MSG_ID_" + msg.name)]
    fields = dict(msg.fields)
    if set(fields) != set(cls.fieldnames):
        raise WireError(
            f"OdidRaw {msg.name} has fields {sorted(fields)}, expected {cls.fieldnames}"
        )
    return _Wire(cls, tuple(fields[name] for name in cls.fieldnames))


def _odid_raw_from(raw: Any) -> m.OdidRaw:
    fields = tuple((name, _freeze(getattr(raw, name))) for name in raw.get_fieldnames())
    return m.OdidRaw(raw.get_type(), fields)


def _freeze(value: Any) -> object:
    return tuple(value) if isinstance(value, list) else value


# --- ridsafe dialect -----------------------------------------------------------------------


def _us(t_s: float) -> int:
    return max(0, round(t_s * 1e6))


def _rid_rssi_to(msg: m.RidRssi) -> _Wire:
    return _wire(
        mav.MAVLink_ridsafe_rid_rssi_message,
        _us(msg.t_s),
        msg.rssi_dbm,
        _id20(msg.id_or_mac),
        msg.odid_message_type,
    )


def _rid_rssi_from(raw: Any) -> m.RidRssi:
    _finite("RIDSAFE_RID_RSSI", raw.rssi_dbm)
    return m.RidRssi(
        raw.time_usec / 1e6, raw.rssi_dbm, _bytes(raw.id_or_mac), raw.odid_message_type
    )


def _uas_id(uas_id: str) -> bytes:
    raw = uas_id.encode("ascii")
    if len(raw) > ODID_ID_LEN:
        raise WireError(f"uas_id {uas_id!r} is longer than {ODID_ID_LEN} characters")
    return raw


def _observation_to(msg: m.Observation) -> _Wire:
    course = msg.claimed_course_deg
    speed_h = msg.claimed_speed_horizontal_m_s
    speed_v = msg.claimed_speed_vertical_m_s
    return _wire(
        mav.MAVLink_ridsafe_observation_message,
        _us(msg.t_s),
        _deg_e7(msg.rx_lat_deg),
        _deg_e7(msg.rx_lon_deg),
        msg.rx_alt_m,
        _deg_e7(msg.claimed_lat_deg),
        _deg_e7(msg.claimed_lon_deg),
        msg.claimed_alt_m,
        msg.rid_timestamp_s,
        msg.rssi_dbm,
        ODID_UNKNOWN_DIRECTION_CDEG if course is None else round(course * 100.0) % 36000,
        ODID_UNKNOWN_SPEED_H_CMS if speed_h is None else min(25425, round(speed_h * 100.0)),
        ODID_UNKNOWN_SPEED_V_CMS if speed_v is None else _cms(speed_v),
        _uas_id(msg.uas_id),
    )


def _observation_from(raw: Any) -> m.Observation:
    rx_lat, rx_lon = raw.rx_lat / DEG_E7, raw.rx_lon / DEG_E7
    c_lat, c_lon = raw.claimed_lat / DEG_E7, raw.claimed_lon / DEG_E7
    _check_lat_lon(rx_lat, rx_lon, "RIDSAFE_OBSERVATION receiver")
    _check_lat_lon(c_lat, c_lon, "RIDSAFE_OBSERVATION claimed")
    _finite("RIDSAFE_OBSERVATION", raw.rx_alt, raw.claimed_alt, raw.rid_timestamp, raw.rssi_dbm)
    return m.Observation(
        t_s=raw.time_usec / 1e6,
        rx_lat_deg=rx_lat,
        rx_lon_deg=rx_lon,
        rx_alt_m=raw.rx_alt,
        claimed_lat_deg=c_lat,
        claimed_lon_deg=c_lon,
        claimed_alt_m=raw.claimed_alt,
        rid_timestamp_s=raw.rid_timestamp,
        rssi_dbm=raw.rssi_dbm,
        claimed_course_deg=None if raw.claimed_direction > 35999 else raw.claimed_direction / 100,
        claimed_speed_horizontal_m_s=None
        if raw.claimed_speed_horizontal == ODID_UNKNOWN_SPEED_H_CMS
        else raw.claimed_speed_horizontal / 100.0,
        claimed_speed_vertical_m_s=None
        if raw.claimed_speed_vertical == ODID_UNKNOWN_SPEED_V_CMS
        else raw.claimed_speed_vertical / 100.0,
        uas_id=_text(raw.uas_id),
    )


def _region_to(msg: m.UnsafeRegionMsg) -> _Wire:
    return _wire(
        mav.MAVLink_ridsafe_unsafe_region_message,
        _us(msg.t_s),
        _us(msg.valid_until_s),
        _deg_e7(msg.center_lat_deg),
        _deg_e7(msg.center_lon_deg),
        msg.center_alt_m,
        list(msg.cov_ned_m2),
        list(msg.v_ned_m_s),
        msg.chi2_threshold,
        msg.alpha,
        msg.track_id,
        msg.flags,
        _uas_id(msg.uas_id),
    )


def _region_from(raw: Any) -> m.UnsafeRegionMsg:
    lat, lon = raw.center_lat / DEG_E7, raw.center_lon / DEG_E7
    _check_lat_lon(lat, lon, "RIDSAFE_UNSAFE_REGION")
    cov = tuple(float(c) for c in raw.cov_ned)
    vel = tuple(float(v) for v in raw.vel_ned)
    _finite("RIDSAFE_UNSAFE_REGION", raw.center_alt, raw.chi2_threshold, *cov, *vel)
    return m.UnsafeRegionMsg(
        raw.time_usec / 1e6,
        raw.valid_until_usec / 1e6,
        lat,
        lon,
        raw.center_alt,
        (cov[0], cov[1], cov[2], cov[3], cov[4], cov[5]),
        (vel[0], vel[1], vel[2]),
        raw.chi2_threshold,
        raw.alpha,
        raw.track_id,
        raw.flags,
        _text(raw.uas_id),
    )


def _alert_to(msg: m.SpoofAlert) -> _Wire:
    return _wire(
        mav.MAVLink_ridsafe_spoof_alert_message,
        _us(msg.t_s),
        msg.statistic,
        msg.threshold,
        msg.detector,
        msg.state,
        _uas_id(msg.uas_id),
    )


def _alert_from(raw: Any) -> m.SpoofAlert:
    return m.SpoofAlert(
        raw.time_usec / 1e6,
        raw.statistic,
        raw.threshold,
        raw.detector,
        raw.state,
        _text(raw.uas_id),
    )


def _tick_to(msg: m.LockstepTick) -> _Wire:
    return _wire(mav.MAVLink_ridsafe_lockstep_tick_message, _us(msg.t_s), msg.tick)


def _tick_from(raw: Any) -> m.LockstepTick:
    return m.LockstepTick(raw.time_usec / 1e6, raw.tick)


def _done_to(msg: m.LockstepDone) -> _Wire:
    return _wire(mav.MAVLink_ridsafe_lockstep_done_message, _us(msg.t_s), msg.tick)


def _done_from(raw: Any) -> m.LockstepDone:
    return m.LockstepDone(raw.time_usec / 1e6, raw.tick)


# --- the tables ------------------------------------------------------------------------------

# domain class -> (MAVLink message name, to-MAVLink, from-MAVLink)
_CODECS: dict[type, tuple[str, ToMav, FromMav]] = {
    m.Heartbeat: ("HEARTBEAT", _heartbeat_to, _heartbeat_from),
    m.CommandLong: ("COMMAND_LONG", _command_long_to, _command_long_from),
    m.CommandAck: ("COMMAND_ACK", _command_ack_to, _command_ack_from),
    m.SetMode: ("SET_MODE", _set_mode_to, _set_mode_from),
    m.SetPositionTargetLocalNed: ("SET_POSITION_TARGET_LOCAL_NED", _spt_to, _spt_from),
    m.GlobalPositionInt: ("GLOBAL_POSITION_INT", _gpi_to, _gpi_from),
    m.LocalPositionNed: ("LOCAL_POSITION_NED", _lpn_to, _lpn_from),
    m.Attitude: ("ATTITUDE", _attitude_to, _attitude_from),
    m.SysStatus: ("SYS_STATUS", _sys_status_to, _sys_status_from),
    m.HomePosition: ("HOME_POSITION", _home_to, _home_from),
    m.SystemTime: ("SYSTEM_TIME", _system_time_to, _system_time_from),
    m.StatusText: ("STATUSTEXT", _statustext_to, _statustext_from),
    m.OdidBasicId: ("OPEN_DRONE_ID_BASIC_ID", _odid_basic_id_to, _odid_basic_id_from),
    m.OdidLocation: ("OPEN_DRONE_ID_LOCATION", _odid_location_to, _odid_location_from),
    m.OdidSystem: ("OPEN_DRONE_ID_SYSTEM", _odid_system_to, _odid_system_from),
    m.OdidSystemUpdate: (
        "OPEN_DRONE_ID_SYSTEM_UPDATE",
        _odid_system_update_to,
        _odid_system_update_from,
    ),
    m.OdidOperatorId: ("OPEN_DRONE_ID_OPERATOR_ID", _odid_operator_id_to, _odid_operator_id_from),
    m.OdidSelfId: ("OPEN_DRONE_ID_SELF_ID", _odid_self_id_to, _odid_self_id_from),
    m.OdidArmStatus: ("OPEN_DRONE_ID_ARM_STATUS", _odid_arm_status_to, _odid_arm_status_from),
    m.RidRssi: ("RIDSAFE_RID_RSSI", _rid_rssi_to, _rid_rssi_from),
    m.Observation: ("RIDSAFE_OBSERVATION", _observation_to, _observation_from),
    m.UnsafeRegionMsg: ("RIDSAFE_UNSAFE_REGION", _region_to, _region_from),
    m.SpoofAlert: ("RIDSAFE_SPOOF_ALERT", _alert_to, _alert_from),
    m.LockstepTick: ("RIDSAFE_LOCKSTEP_TICK", _tick_to, _tick_from),
    m.LockstepDone: ("RIDSAFE_LOCKSTEP_DONE", _done_to, _done_from),
}
_FROM_NAME: dict[str, FromMav] = {name: dec for name, _, dec in _CODECS.values()}
for _name in _RAW_ODID_NAMES:
    _FROM_NAME[_name] = _odid_raw_from


def to_mavlink(message: m.Message) -> Any:
    """The pymavlink message object for a domain message (raises WireError if unencodable)."""
    wire = _to_wire(message)
    return wire.cls(*wire.args)


def _to_wire(message: m.Message) -> _Wire:
    if isinstance(message, m.OdidRaw):
        return _odid_raw_to(message)
    try:
        _, encode, _ = _CODECS[type(message)]
    except KeyError:
        raise WireError(f"no MAVLink encoding for {type(message).__name__}") from None
    return encode(message)


def from_mavlink(raw: Any) -> m.Message | None:
    """The domain message for a pymavlink message, or None if the apps do not use it.

    Raises WireError for values that no valid sender produces (latitude 91 deg, NaN RSSI).
    """
    decode = _FROM_NAME.get(raw.get_type())
    return None if decode is None else decode(raw)


def odid_fields(message: m.Message) -> tuple[str, dict[str, object]]:
    """MAVLink message name and field values (the form F3411 encoding works on): the
    arguments a pymavlink message would be built from, extensions defaulted, char arrays as
    text and arrays as lists."""
    wire = _to_wire(message)
    defaults = _wire_plan(wire.cls)[3]
    args = wire.args + defaults[len(wire.args) :]
    names = wire.cls.fieldnames
    fields = {name: _plain(value) for name, value in zip(names, args, strict=True)}
    return wire.cls.msgname, fields


def message_from_fields(name: str, fields: dict[str, object]) -> m.Message:
    """The domain message for MAVLink field values (inverse of ``odid_fields``)."""
    cls = mav.mavlink_map.get(getattr(mav, "MAVLINK_MSG_ID_" + name, -1))
    if cls is None:
        raise WireError(f"unknown MAVLink message {name!r}")
    values = {k: (v.encode("latin-1") if isinstance(v, str) else v) for k, v in fields.items()}
    raw = cls(**values)
    decoded = from_mavlink(raw)
    if decoded is None:
        raise WireError(f"{name} has no domain message")
    return decoded


def _plain(value: Any) -> object:
    if isinstance(value, bytes):
        return value.rstrip(b"\x00").decode("latin-1")
    return list(value) if isinstance(value, list | tuple) else value


# --- the receive path: a MAVLink 2 parser over whole buffers -------------------------------
#
# pymavlink's parser works a byte at a time and builds a message object per packet; on the
# hot path (a 16-aircraft lockstep run moves ~200k messages) that cost 3x what this does:
# find packets with bytes.find, check the CRC with binascii, unpack the payload with the
# message's own struct and hand the fields to the domain conversion as attributes.

_STX_V1 = 0xFE
_STX_V2 = 0xFD
_HEADER_LEN = 10
_NEW_STREAM_SLACK = 6000 * 1000  # signing timestamp units (10 us): one minute
_CRC_LEN = 2
_SIGNATURE_LEN = 13
_BIT_REVERSED = bytes(int(f"{i:08b}"[::-1], 2) for i in range(256))


def x25_crc(data: bytes) -> int:
    """MAVLink's CRC-16/MCRF4XX (X.25): the reflected form of CRC-CCITT, computed with
    binascii.crc_hqx on bit-reversed bytes and bit-reversed back."""
    crc = binascii.crc_hqx(data.translate(_BIT_REVERSED), 0xFFFF)
    return _BIT_REVERSED[crc & 0xFF] << 8 | _BIT_REVERSED[crc >> 8]


_HEADER = struct.Struct("<BBBBBBBHB")
_IFLAG_SIGNED = mav.MAVLINK_IFLAG_SIGNED


def _wire_values(wire: _Wire) -> tuple[Any, ...] | list[Any]:
    """The values ``wire.cls.unpacker`` packs: the fields in wire order, arrays flattened,
    char arrays as bytes."""
    getter, arrays, chars, defaults = _wire_plan(wire.cls)
    args = wire.args
    if len(args) < len(defaults):  # extension fields left to their constructor defaults
        args = args + defaults[len(args) :]
    values = getter(args)
    if not (arrays or chars):  # scalars only, the common case: one C call
        return values if isinstance(values, tuple) else (values,)
    out = list(values)
    for index in chars:
        if isinstance(out[index], str):
            out[index] = out[index].encode("latin-1")
    for index in reversed(arrays):  # from the end: earlier indices stay valid
        out[index : index + 1] = out[index]
    return out


@functools.cache
def _wire_plan(
    cls: Any,
) -> tuple[Callable[[Any], Any], tuple[int, ...], tuple[int, ...], tuple[Any, ...]]:
    """(getter of the wire-ordered fields from the constructor arguments, wire indices of
    arrays, wire indices of char arrays, the constructor's defaults) of a message class.
    ``cls.orders[i]`` is the wire position of XML field i; ``array_lengths`` is in wire
    order, ``fieldtypes`` in XML order."""
    xml_of_wire = sorted(range(len(cls.orders)), key=lambda i: cls.orders[i])
    is_char = [cls.fieldtypes[i].startswith("char") for i in xml_of_wire]
    arrays = tuple(w for w, n in enumerate(cls.array_lengths) if n > 0 and not is_char[w])
    chars = tuple(w for w, char in enumerate(is_char) if char)
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]  # after self
    defaults = tuple(p.default for p in parameters)
    return operator.itemgetter(*xml_of_wire), arrays, chars, defaults


def _view_type(name: str, fieldnames: tuple[str, ...]) -> Callable[[Iterable[Any]], Any]:
    """The maker of a decoded packet's view: a named tuple of the fields in XML order, read
    as attributes by the from-MAVLink functions, with pymavlink's ``get_type`` and
    ``get_fieldnames`` (a tuple is built in one C call, where an object with a ``__dict__``
    took one store per field)."""
    fields = collections.namedtuple(f"{name}_view", fieldnames)  # type: ignore[misc]
    view: Any = type(
        fields.__name__,
        (fields,),
        {
            "__slots__": (),
            "get_type": lambda self: name,
            "get_fieldnames": lambda self: fieldnames,
        },
    )
    return view._make  # type: ignore[no-any-return]


@dataclass(frozen=True)
class _Layout:
    """How to unpack one message id: its struct, CRC extra and fields in XML order."""

    name: str
    crc_extra_byte: bytes
    unpacker: struct.Struct
    slices: tuple[tuple[int, int], ...]  # per field: (index in the unpacked tuple, length)
    # The first unpacked item of every field, in XML order, in one C call; then the few
    # fields that are more than that: arrays (field index, tip, length) and char arrays.
    firsts: Callable[[tuple[Any, ...]], Any]
    arrays: tuple[tuple[int, int, int], ...]
    chars: tuple[int, ...]
    make_view: Callable[[Iterable[Any]], Any]
    decode: FromMav | None  # the domain message of a view; None: the apps do not use it

    def view(self, payload: bytes) -> Any:
        if len(payload) < self.unpacker.size:  # MAVLink 2 trims trailing zero bytes
            payload = payload + bytes(self.unpacker.size - len(payload))
        t = self.unpacker.unpack(payload[: self.unpacker.size])
        firsts = self.firsts(t)
        if len(self.slices) == 1:
            firsts = (firsts,)
        if not (self.arrays or self.chars):
            return self.make_view(firsts)
        values = list(firsts)
        for index, tip, length in self.arrays:
            values[index] = t[tip : tip + length]
        for index in self.chars:
            values[index] = values[index].rstrip(b"\x00")
        return self.make_view(values)


@functools.cache
def _layout(msg_id: int) -> _Layout | None:
    cls = mav.mavlink_map.get(msg_id)
    if cls is None:
        return None
    lengths = cls.lengths
    tips = [sum(lengths[:order]) for order in cls.orders]
    slices = tuple((tip, lengths[order]) for tip, order in zip(tips, cls.orders, strict=True))
    firsts = cls.unpacker.unpack(bytes(cls.unpacker.size))
    return _Layout(
        cls.msgname,
        _CRC_EXTRA_BYTE[cls.crc_extra],
        cls.unpacker,
        slices,
        operator.itemgetter(*(tip for tip, _ in slices)),
        tuple((i, tip, length) for i, (tip, length) in enumerate(slices) if length > 1),
        tuple(i for i, (tip, _) in enumerate(slices) if isinstance(firsts[tip], bytes)),
        _view_type(cls.msgname, tuple(cls.fieldnames)),
        _FROM_NAME.get(cls.msgname),
    )


# Payloads of the messages packed last, by identity: the sim hands one decoded RID frame to
# every receiver, so the same (immutable) message object is packed once per receiver. Keeping
# the object in the cache keeps its id from being reused while the entry lives.
_PAYLOAD_CACHE_SIZE = 512
_payloads: dict[int, tuple[m.Message, int, bytes, bytes]] = {}
_CRC_EXTRA_BYTE = tuple(bytes([extra]) for extra in range(256))


def _payload(message: m.Message) -> tuple[int, bytes, bytes]:
    """(message id, CRC extra as one byte, payload bytes as sent: MAVLink 2 trims trailing
    zeros but keeps at least one byte) of a domain message."""
    cached = _payloads.get(id(message))
    if cached is not None and cached[0] is message:
        return cached[1], cached[2], cached[3]
    wire = _to_wire(message)
    payload = wire.cls.unpacker.pack(*_wire_values(wire))
    payload = payload.rstrip(b"\x00") or payload[:1]
    entry = (message, wire.cls.id, _CRC_EXTRA_BYTE[wire.cls.crc_extra], payload)
    if len(_payloads) >= _PAYLOAD_CACHE_SIZE:
        _payloads.clear()
    _payloads[id(message)] = entry
    return entry[1], entry[2], entry[3]


# Domain messages of the Remote ID payloads decoded last, by message id + payload bytes: a
# broadcast reaches every receiver with the same bytes, and decoding is a pure function of
# them (the messages are immutable), so the receivers in one process share one decode.
_DECODED_CACHE_SIZE = 1024
_SHARED_IDS = frozenset(
    getattr(mav, "MAVLINK_MSG_ID_" + name)
    for name in (
        "OPEN_DRONE_ID_BASIC_ID",
        "OPEN_DRONE_ID_LOCATION",
        "OPEN_DRONE_ID_AUTHENTICATION",
        "OPEN_DRONE_ID_SELF_ID",
        "OPEN_DRONE_ID_SYSTEM",
        "OPEN_DRONE_ID_OPERATOR_ID",
        "OPEN_DRONE_ID_MESSAGE_PACK",
    )
)
_decoded: dict[bytes, m.Message] = {}


# --- one end of a link ----------------------------------------------------------------------


class MavlinkLink:
    """One end of a MAVLink 2 link, sans I/O.

    ``src_system`` / ``src_component`` stamp outgoing packets. With ``signing`` set, every
    outgoing packet is signed and incoming packets must carry a valid signature: unsigned
    or wrongly signed ones are dropped and counted in ``counters.rejected_signature``.
    """

    def __init__(
        self, src_system: int, src_component: int, signing: SigningConfig | None = None
    ) -> None:
        self._mav = mav.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._system, self._component, self._seq = src_system, src_component, 0
        self._incompat_flags = 0 if signing is None else mav.MAVLINK_IFLAG_SIGNED
        self._pending = b""
        self.counters = LinkCounters()
        self.signing = signing
        if signing is not None:
            self._mav.signing.secret_key = signing.key
            self._mav.signing.sign_outgoing = True
            self._mav.signing.link_id = signing.link_id
            self._mav.signing.timestamp = signing.initial_timestamp

    @property
    def src_system(self) -> int:
        return self._system

    @property
    def src_component(self) -> int:
        return self._component

    def pack(self, message: m.Message) -> bytes:
        """Encode one message as one MAVLink 2 packet and advance the sequence number: the
        bytes pymavlink's ``pack`` produces, without its per-packet objects."""
        msg_id, crc_extra, payload = _payload(message)
        seq = self._seq
        self._seq = (seq + 1) & 0xFF
        packet = (
            _HEADER.pack(
                _STX_V2,
                len(payload),
                self._incompat_flags,
                0,
                seq,
                self._system,
                self._component,
                msg_id & 0xFFFF,
                msg_id >> 16,
            )
            + payload
        )
        packet += x25_crc(packet[1:] + crc_extra).to_bytes(2, "little")
        if self.signing is None:
            return packet
        state = self._mav.signing
        packet += struct.pack("<BQ", state.link_id, state.timestamp)[:7]
        state.timestamp += 1
        return packet + hashlib.sha256(state.secret_key + packet).digest()[:6]

    def pack_all(self, messages: list[m.Message]) -> bytes:
        return b"".join(self.pack(message) for message in messages)

    def feed(self, data: bytes, end_of_datagram: bool = True) -> list[Received]:
        """Parse bytes; return the accepted messages.

        Over UDP a MAVLink packet never spans datagrams, so by default a partial packet left
        at the end of ``data`` is dropped (counted as ``truncated``) instead of swallowing
        the start of the next datagram. Pass ``end_of_datagram=False`` for a byte stream
        (serial, TCP) where packets may be split across reads.
        """
        data = data if type(data) is bytes else bytes(data)
        buf = self._pending + data if self._pending else data
        self._pending = b""
        received: list[Received] = []
        i, n = 0, len(buf)
        while i < n:
            if buf[i] != _STX_V2:
                i = self._skip_garbage(buf, i)
                continue
            if n - i < _HEADER_LEN + _CRC_LEN:
                break
            mlen, incompat = buf[i + 1], buf[i + 2]
            if incompat & ~_IFLAG_SIGNED:
                self._drop("bad_data", f"unknown incompat_flags 0x{incompat:02x}")
                i += 1
                continue
            end = i + _HEADER_LEN + mlen + _CRC_LEN
            if incompat & _IFLAG_SIGNED:
                end += _SIGNATURE_LEN
            if end > n:
                break
            consumed, item = self._decode_packet(buf[i:end], mlen)
            if item is not None:
                received.append(item)
            i += consumed
        if i < n:
            if end_of_datagram:
                self._drop("truncated", f"{n - i} bytes of a partial packet")
            else:
                self._pending = buf[i:]
        return received

    def _skip_garbage(self, buf: bytes, i: int) -> int:
        """Drop bytes up to the next MAVLink 2 start marker; returns where it is."""
        j = buf.find(b"\xfd", i + 1)
        j = len(buf) if j < 0 else j
        what = "a MAVLink 1 packet (MAVLink 2 only)" if buf[i] == _STX_V1 else "garbage"
        self._drop("bad_data", f"{j - i} bytes of {what}")
        return j

    def _decode_packet(self, packet: bytes, mlen: int) -> tuple[int, Received | None]:
        """Check and decode one complete packet; returns (bytes consumed, message or None).

        A packet whose CRC does not match consumes one byte only, so a false start marker
        inside garbage cannot hide the real packet that follows.
        """
        src_system, src_component = packet[5], packet[6]
        msg_id = packet[7] | packet[8] << 8 | packet[9] << 16
        layout = _layout(msg_id)
        if layout is None:
            self._drop("unknown_id", f"unknown message id {msg_id} from {src_system}")
            return len(packet), None
        crc_end = _HEADER_LEN + mlen
        crc = packet[crc_end] | packet[crc_end + 1] << 8
        if crc != x25_crc(packet[1:crc_end] + layout.crc_extra_byte):
            self._drop("bad_data", f"CRC mismatch in message {msg_id} from {src_system}")
            return 1, None
        signed = len(packet) > crc_end + _CRC_LEN
        if self.signing is not None and not self._signature_ok(
            packet, signed, src_system, src_component
        ):
            return len(packet), None
        key = packet[7:crc_end]  # message id and payload
        message = _decoded.get(key)
        if message is None and layout.decode is not None:
            try:
                message = layout.decode(layout.view(packet[_HEADER_LEN:crc_end]))
            except (WireError, ValueError, TypeError, UnicodeDecodeError) as exc:
                self._drop("invalid_value", f"{layout.name} from {src_system}: {exc}")
                return len(packet), None
            if msg_id in _SHARED_IDS and message is not None:
                if len(_decoded) >= _DECODED_CACHE_SIZE:
                    _decoded.clear()
                _decoded[key] = message
        if message is None:
            self.counters.unhandled += 1
            logger.debug("ignoring %s from %d", layout.name, src_system)
            return len(packet), None
        self.counters.accepted += 1
        return len(packet), Received(src_system, src_component, message, signed)

    def _signature_ok(self, packet: bytes, signed: bool, system: int, component: int) -> bool:
        """With a key: a valid, fresh signature is required (SHA-256 of key + packet, then
        pymavlink's per-stream timestamp check). The signature is verified first, so a forged
        packet cannot advance a stream's timestamp and make genuine packets look replayed.
        Without a key: anything goes."""
        if self.signing is None:
            return True
        if not signed:
            self._drop("rejected_signature", f"unsigned packet from {system}/{component}")
            return False
        expected = hashlib.sha256(self.signing.key + packet[:-6]).digest()[:6]
        if expected != packet[-6:]:
            self._drop("rejected_signature", f"forged signature from {system}/{component}")
            return False
        return self._fresh(packet, system, component)

    def _fresh(self, packet: bytes, system: int, component: int) -> bool:
        """The MAVLink 2 signing timestamp rule (pymavlink's ``check_signature``, whose hash
        check has been done): per (link id, system, component) stream the timestamp must
        grow; a new stream may be at most a minute behind this link's clock, which then
        moves up to the newest timestamp accepted."""
        state = self._mav.signing
        timestamp = int.from_bytes(packet[-12:-6], "little")
        stream = (packet[-13], system, component)
        last = state.stream_timestamps.get(stream)
        if last is not None and timestamp <= last:
            self._drop("rejected_signature", f"replayed signature from {system}/{component}")
            return False
        if last is None and timestamp + _NEW_STREAM_SLACK < state.timestamp:
            self._drop("rejected_signature", f"stale new stream from {system}/{component}")
            return False
        state.stream_timestamps[stream] = timestamp
        state.timestamp = max(state.timestamp, timestamp)
        return True

    def _drop(self, kind: str, reason: str) -> None:
        """Count a drop; warn on the first of each kind and then every 1000th (a stream of
        garbage must not flood the log), debug otherwise."""
        count = getattr(self.counters, kind) + 1
        setattr(self.counters, kind, count)
        self.counters.last_error = reason
        level = logging.WARNING if count == 1 or count % 1000 == 0 else logging.DEBUG
        logger.log(
            level,
            "link %d/%d dropped %s (%d so far): %s",
            self.src_system,
            self.src_component,
            kind,
            count,
            reason,
        )
