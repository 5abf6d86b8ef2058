"""Open Drone ID (OPEN_DRONE_ID_*) messages: domain message <-> MAVLink field values.

"Unknown" sentinels of F3411 (direction 361 deg, speed 255 cm/s, altitude -1000 m, timestamp
0xFFFF, lat = lon = 0) map to None. AUTHENTICATION and MESSAGE_PACK pass through as
``OdidRaw`` (their field values; nothing in the apps reads inside them here).
"""

from __future__ import annotations

from typing import Any

from ridsafe.common import messages as m
from ridsafe.common.codec.units import (
    DEG_E7,
    ODID_UNKNOWN_ALT_M,
    ODID_UNKNOWN_DIRECTION_CDEG,
    ODID_UNKNOWN_SPEED_H_CMS,
    ODID_UNKNOWN_SPEED_V_CMS,
    ODID_UNKNOWN_TIMESTAMP_S,
    CodecTable,
    Wire,
    check_finite,
    check_lat_lon,
    deg_e7,
    id20,
    id_from_wire,
    or_unknown,
    text,
    unknown_to_none,
    wire,
)
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError


def _odid_location_to(msg: m.OdidLocation) -> Wire:
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
    return wire(
        mav.MAVLink_open_drone_id_location_message,
        0,
        0,
        id20(msg.id_or_mac),
        msg.status,
        direction,
        speed_h,
        speed_v,
        deg_e7(msg.lat_deg) if known and msg.lat_deg is not None else 0,
        deg_e7(msg.lon_deg) if known and msg.lon_deg is not None else 0,
        or_unknown(msg.alt_baro_m, ODID_UNKNOWN_ALT_M),
        or_unknown(msg.alt_geodetic_m, ODID_UNKNOWN_ALT_M),
        msg.height_reference,
        or_unknown(msg.height_m, ODID_UNKNOWN_ALT_M),
        msg.horizontal_accuracy,
        msg.vertical_accuracy,
        msg.barometer_accuracy,
        msg.speed_accuracy,
        or_unknown(msg.timestamp_s, ODID_UNKNOWN_TIMESTAMP_S),
        msg.timestamp_accuracy,
    )


def _odid_location_from(raw: Any) -> m.OdidLocation:
    known = not (raw.latitude == 0 and raw.longitude == 0)
    lat, lon = raw.latitude / DEG_E7, raw.longitude / DEG_E7
    if known:
        check_lat_lon(lat, lon, "OPEN_DRONE_ID_LOCATION")
    check_finite(
        "OPEN_DRONE_ID_LOCATION", raw.altitude_geodetic, raw.altitude_barometric, raw.height
    )
    return m.OdidLocation(
        id_or_mac=id_from_wire(raw.id_or_mac),
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
        alt_baro_m=unknown_to_none(raw.altitude_barometric, ODID_UNKNOWN_ALT_M),
        alt_geodetic_m=unknown_to_none(raw.altitude_geodetic, ODID_UNKNOWN_ALT_M),
        height_reference=raw.height_reference,
        height_m=unknown_to_none(raw.height, ODID_UNKNOWN_ALT_M),
        horizontal_accuracy=raw.horizontal_accuracy,
        vertical_accuracy=raw.vertical_accuracy,
        barometer_accuracy=raw.barometer_accuracy,
        speed_accuracy=raw.speed_accuracy,
        timestamp_s=unknown_to_none(raw.timestamp, ODID_UNKNOWN_TIMESTAMP_S),
        timestamp_accuracy=raw.timestamp_accuracy,
    )


def _odid_basic_id_to(msg: m.OdidBasicId) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_basic_id_message,
        0,
        0,
        id20(msg.id_or_mac),
        msg.id_type,
        msg.ua_type,
        id20(msg.uas_id),
    )


def _odid_basic_id_from(raw: Any) -> m.OdidBasicId:
    return m.OdidBasicId(
        id_from_wire(raw.id_or_mac), raw.id_type, raw.ua_type, id_from_wire(raw.uas_id)
    )


def _opt_latlon(value_e7: int, other_e7: int) -> float | None:
    return None if value_e7 == 0 and other_e7 == 0 else value_e7 / DEG_E7


def _odid_system_to(msg: m.OdidSystem) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_system_message,
        0,
        0,
        id20(msg.id_or_mac),
        msg.operator_location_type,
        msg.classification_type,
        0 if msg.operator_lat_deg is None else deg_e7(msg.operator_lat_deg),
        0 if msg.operator_lon_deg is None else deg_e7(msg.operator_lon_deg),
        msg.area_count,
        msg.area_radius_m,
        or_unknown(msg.area_ceiling_m, ODID_UNKNOWN_ALT_M),
        or_unknown(msg.area_floor_m, ODID_UNKNOWN_ALT_M),
        msg.category_eu,
        msg.class_eu,
        or_unknown(msg.operator_alt_geo_m, ODID_UNKNOWN_ALT_M),
        msg.timestamp_s,
    )


def _odid_system_from(raw: Any) -> m.OdidSystem:
    lat = _opt_latlon(raw.operator_latitude, raw.operator_longitude)
    lon = _opt_latlon(raw.operator_longitude, raw.operator_latitude)
    if lat is not None and lon is not None:
        check_lat_lon(lat, lon, "OPEN_DRONE_ID_SYSTEM")
    return m.OdidSystem(
        id_from_wire(raw.id_or_mac),
        raw.operator_location_type,
        raw.classification_type,
        lat,
        lon,
        raw.area_count,
        raw.area_radius,
        unknown_to_none(raw.area_ceiling, ODID_UNKNOWN_ALT_M),
        unknown_to_none(raw.area_floor, ODID_UNKNOWN_ALT_M),
        raw.category_eu,
        raw.class_eu,
        unknown_to_none(raw.operator_altitude_geo, ODID_UNKNOWN_ALT_M),
        raw.timestamp,
    )


def _odid_system_update_to(msg: m.OdidSystemUpdate) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_system_update_message,
        0,
        0,
        0 if msg.operator_lat_deg is None else deg_e7(msg.operator_lat_deg),
        0 if msg.operator_lon_deg is None else deg_e7(msg.operator_lon_deg),
        or_unknown(msg.operator_alt_geo_m, ODID_UNKNOWN_ALT_M),
        msg.timestamp_s,
    )


def _odid_system_update_from(raw: Any) -> m.OdidSystemUpdate:
    return m.OdidSystemUpdate(
        _opt_latlon(raw.operator_latitude, raw.operator_longitude),
        _opt_latlon(raw.operator_longitude, raw.operator_latitude),
        unknown_to_none(raw.operator_altitude_geo, ODID_UNKNOWN_ALT_M),
        raw.timestamp,
    )


def _odid_operator_id_to(msg: m.OdidOperatorId) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_operator_id_message,
        0,
        0,
        id20(msg.id_or_mac),
        msg.operator_id_type,
        msg.operator_id.encode("ascii")[:20],
    )


def _odid_operator_id_from(raw: Any) -> m.OdidOperatorId:
    return m.OdidOperatorId(
        id_from_wire(raw.id_or_mac), raw.operator_id_type, text(raw.operator_id)
    )


def _odid_self_id_to(msg: m.OdidSelfId) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_self_id_message,
        0,
        0,
        id20(msg.id_or_mac),
        msg.description_type,
        msg.description.encode("ascii")[:23],
    )


def _odid_self_id_from(raw: Any) -> m.OdidSelfId:
    return m.OdidSelfId(id_from_wire(raw.id_or_mac), raw.description_type, text(raw.description))


def _odid_arm_status_to(msg: m.OdidArmStatus) -> Wire:
    return wire(
        mav.MAVLink_open_drone_id_arm_status_message, msg.status, msg.error.encode("ascii")[:50]
    )


def _odid_arm_status_from(raw: Any) -> m.OdidArmStatus:
    return m.OdidArmStatus(raw.status, text(raw.error))


#: Passed through as ``OdidRaw`` (one domain class for both, so looked up by name).
RAW_NAMES = ("OPEN_DRONE_ID_AUTHENTICATION", "OPEN_DRONE_ID_MESSAGE_PACK")


def odid_raw_to(msg: m.OdidRaw) -> Wire:
    if msg.name not in RAW_NAMES:
        raise WireError(f"OdidRaw carries {msg.name}, expected one of {RAW_NAMES}")
    cls = mav.mavlink_map[getattr(mav, "MAVLINK_MSG_ID_" + msg.name)]
    fields = dict(msg.fields)
    if set(fields) != set(cls.fieldnames):
        raise WireError(
            f"OdidRaw {msg.name} has fields {sorted(fields)}, expected {cls.fieldnames}"
        )
    return Wire(cls, tuple(fields[name] for name in cls.fieldnames))


def odid_raw_from(raw: Any) -> m.OdidRaw:
    fields = tuple((name, _freeze(getattr(raw, name))) for name in raw.get_fieldnames())
    return m.OdidRaw(raw.get_type(), fields)


def _freeze(value: Any) -> object:
    return tuple(value) if isinstance(value, list) else value


CODECS: CodecTable = {
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
}
