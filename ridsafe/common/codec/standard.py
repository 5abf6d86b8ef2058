"""common.xml messages the apps use: domain message <-> MAVLink field values.

Each message has a ``_x_to`` (domain -> ``Wire``: pymavlink class and its constructor arguments
in MAVLink units) and a ``_x_from`` (decoded fields, read as attributes -> domain message), and
one line in ``CODECS``. A ``_from`` raises WireError for values no valid sender produces.
"""

from __future__ import annotations

from typing import Any

from ridsafe.common import messages as m
from ridsafe.common.codec.units import (
    DEG_E7,
    CodecTable,
    Wire,
    check_finite,
    check_lat_lon,
    cms,
    deg_e7,
    ms,
    vec3,
    wire,
)
from ridsafe.common.dialect import ridsafe_v20 as mav


def _heartbeat_to(msg: m.Heartbeat) -> Wire:
    return wire(
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


def _command_long_to(msg: m.CommandLong) -> Wire:
    return wire(
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


def _command_ack_to(msg: m.CommandAck) -> Wire:
    return wire(
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


def _set_mode_to(msg: m.SetMode) -> Wire:
    return wire(mav.MAVLink_set_mode_message, msg.target_system, msg.base_mode, msg.custom_mode)


def _set_mode_from(raw: Any) -> m.SetMode:
    return m.SetMode(raw.target_system, raw.base_mode, raw.custom_mode)


def _spt_to(msg: m.SetPositionTargetLocalNed) -> Wire:
    return wire(
        mav.MAVLink_set_position_target_local_ned_message,
        ms(msg.time_boot_s),
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
        vec3(raw.x, raw.y, raw.z),
        vec3(raw.vx, raw.vy, raw.vz),
        vec3(raw.afx, raw.afy, raw.afz),
        raw.yaw,
        raw.yaw_rate,
    )


def _gpi_to(msg: m.GlobalPositionInt) -> Wire:
    hdg = 65535 if msg.heading_deg is None else round(msg.heading_deg * 100.0) % 36000
    return wire(
        mav.MAVLink_global_position_int_message,
        ms(msg.time_boot_s),
        deg_e7(msg.lat_deg),
        deg_e7(msg.lon_deg),
        round(msg.alt_msl_m * 1000.0),
        round(msg.relative_alt_m * 1000.0),
        *(cms(v) for v in msg.v_ned_m_s),
        hdg,
    )


def _gpi_from(raw: Any) -> m.GlobalPositionInt:
    lat, lon = raw.lat / DEG_E7, raw.lon / DEG_E7
    check_lat_lon(lat, lon, "GLOBAL_POSITION_INT")
    return m.GlobalPositionInt(
        raw.time_boot_ms / 1000.0,
        lat,
        lon,
        raw.alt / 1000.0,
        raw.relative_alt / 1000.0,
        vec3(raw.vx / 100.0, raw.vy / 100.0, raw.vz / 100.0),
        None if raw.hdg == 65535 else raw.hdg / 100.0,
    )


def _lpn_to(msg: m.LocalPositionNed) -> Wire:
    return wire(
        mav.MAVLink_local_position_ned_message, ms(msg.time_boot_s), *msg.p_ned_m, *msg.v_ned_m_s
    )


def _lpn_from(raw: Any) -> m.LocalPositionNed:
    check_finite("LOCAL_POSITION_NED", raw.x, raw.y, raw.z, raw.vx, raw.vy, raw.vz)
    return m.LocalPositionNed(
        raw.time_boot_ms / 1000.0, vec3(raw.x, raw.y, raw.z), vec3(raw.vx, raw.vy, raw.vz)
    )


def _attitude_to(msg: m.Attitude) -> Wire:
    return wire(
        mav.MAVLink_attitude_message,
        ms(msg.time_boot_s),
        msg.roll_rad,
        msg.pitch_rad,
        msg.yaw_rad,
        *msg.rates_frd_rad_s,
    )


def _attitude_from(raw: Any) -> m.Attitude:
    check_finite("ATTITUDE", raw.roll, raw.pitch, raw.yaw)
    return m.Attitude(
        raw.time_boot_ms / 1000.0,
        raw.roll,
        raw.pitch,
        raw.yaw,
        vec3(raw.rollspeed, raw.pitchspeed, raw.yawspeed),
    )


def _sys_status_to(msg: m.SysStatus) -> Wire:
    volt_mv = 65535 if msg.battery_voltage_v is None else round(msg.battery_voltage_v * 1e3)
    remaining = -1 if msg.battery_remaining_pct is None else msg.battery_remaining_pct
    return wire(
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


def _home_to(msg: m.HomePosition) -> Wire:
    return wire(
        mav.MAVLink_home_position_message,
        deg_e7(msg.lat_deg),
        deg_e7(msg.lon_deg),
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
    check_lat_lon(lat, lon, "HOME_POSITION")
    return m.HomePosition(lat, lon, raw.altitude / 1000.0, vec3(raw.x, raw.y, raw.z))


def _system_time_to(msg: m.SystemTime) -> Wire:
    return wire(mav.MAVLink_system_time_message, round(msg.time_unix_s * 1e6), ms(msg.time_boot_s))


def _system_time_from(raw: Any) -> m.SystemTime:
    return m.SystemTime(raw.time_unix_usec / 1e6, raw.time_boot_ms / 1000.0)


def _statustext_to(msg: m.StatusText) -> Wire:
    return wire(
        mav.MAVLink_statustext_message, msg.severity, msg.text.encode("ascii", "replace")[:50]
    )


def _statustext_from(raw: Any) -> m.StatusText:
    text = raw.text if isinstance(raw.text, str) else bytes(raw.text).decode("ascii", "replace")
    return m.StatusText(raw.severity, text)


CODECS: CodecTable = {
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
}
