"""Conversions of the ground-station protocol messages (:mod:`ridsafe.common.protocol_messages`):
parameters, missions, COMMAND_INT, the extra telemetry. Same shape as ``standard``.

Global frames carry latitude and longitude as degE7 integers in COMMAND_INT / MISSION_ITEM_INT
``x``/``y``; local frames carry metres x 1e4 (MAV_FRAME_LOCAL_* in the _INT messages).
"""

from __future__ import annotations

from typing import Any

from ridsafe.common import protocol_messages as p
from ridsafe.common.codec.units import CodecTable, Wire, check_finite, ms, text, wire
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError

# MAV_FRAME values whose x/y are latitude/longitude.
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
_LOCAL_INT_SCALE = 1e4


def _xy_to_int(frame: int, x: float, y: float) -> tuple[int, int]:
    scale = 1e7 if frame in GLOBAL_FRAMES else _LOCAL_INT_SCALE
    return round(x * scale), round(y * scale)


def _xy_from_int(frame: int, x: int, y: int) -> tuple[float, float]:
    scale = 1e7 if frame in GLOBAL_FRAMES else _LOCAL_INT_SCALE
    return x / scale, y / scale


def _params_from(raw: Any, x: float, y: float) -> p.Params7:
    return (
        float(raw.param1),
        float(raw.param2),
        float(raw.param3),
        float(raw.param4),
        float(x),
        float(y),
        float(raw.z),
    )


def _param_id(value: Any) -> str:
    name = text(value) if isinstance(value, bytes | str) else str(value)
    return name.split("\x00", 1)[0]


def _command_int_to(msg: p.CommandInt) -> Wire:
    x, y = _xy_to_int(msg.frame, msg.params[4], msg.params[5])
    return wire(
        mav.MAVLink_command_int_message,
        msg.target_system,
        msg.target_component,
        msg.frame,
        msg.command,
        msg.current,
        msg.autocontinue,
        *msg.params[:4],
        x,
        y,
        msg.params[6],
    )


def _command_int_from(raw: Any) -> p.CommandInt:
    x, y = _xy_from_int(raw.frame, raw.x, raw.y)
    return p.CommandInt(
        raw.target_system,
        raw.target_component,
        raw.frame,
        raw.command,
        raw.current,
        raw.autocontinue,
        _params_from(raw, x, y),
    )


def _param_request_list_to(msg: p.ParamRequestList) -> Wire:
    return wire(mav.MAVLink_param_request_list_message, msg.target_system, msg.target_component)


def _param_request_list_from(raw: Any) -> p.ParamRequestList:
    return p.ParamRequestList(raw.target_system, raw.target_component)


def _param_request_read_to(msg: p.ParamRequestRead) -> Wire:
    return wire(
        mav.MAVLink_param_request_read_message,
        msg.target_system,
        msg.target_component,
        msg.param_id.encode("ascii"),
        msg.param_index,
    )


def _param_request_read_from(raw: Any) -> p.ParamRequestRead:
    return p.ParamRequestRead(
        raw.target_system, raw.target_component, _param_id(raw.param_id), raw.param_index
    )


def _param_set_to(msg: p.ParamSet) -> Wire:
    return wire(
        mav.MAVLink_param_set_message,
        msg.target_system,
        msg.target_component,
        msg.param_id.encode("ascii"),
        msg.value,
        msg.param_type,
    )


def _param_set_from(raw: Any) -> p.ParamSet:
    return p.ParamSet(
        raw.target_system,
        raw.target_component,
        _param_id(raw.param_id),
        float(raw.param_value),
        raw.param_type,
    )


def _param_value_to(msg: p.ParamValue) -> Wire:
    return wire(
        mav.MAVLink_param_value_message,
        msg.param_id.encode("ascii"),
        msg.value,
        msg.param_type,
        msg.param_count,
        msg.param_index,
    )


def _param_value_from(raw: Any) -> p.ParamValue:
    return p.ParamValue(
        _param_id(raw.param_id),
        float(raw.param_value),
        raw.param_type,
        raw.param_count,
        raw.param_index,
    )


def _autopilot_version_to(msg: p.AutopilotVersion) -> Wire:
    zeros8 = [0] * 8
    return wire(
        mav.MAVLink_autopilot_version_message,
        msg.capabilities,
        msg.flight_sw_version,
        0,
        0,
        msg.board_version,
        zeros8,
        zeros8,
        zeros8,
        msg.vendor_id,
        msg.product_id,
        msg.uid,
        [0] * 18,
    )


def _autopilot_version_from(raw: Any) -> p.AutopilotVersion:
    return p.AutopilotVersion(
        raw.capabilities,
        raw.flight_sw_version,
        raw.board_version,
        raw.vendor_id,
        raw.product_id,
        raw.uid,
    )


def _ess_to(msg: p.ExtendedSysState) -> Wire:
    return wire(mav.MAVLink_extended_sys_state_message, msg.vtol_state, msg.landed_state)


def _ess_from(raw: Any) -> p.ExtendedSysState:
    return p.ExtendedSysState(raw.vtol_state, raw.landed_state)


def _gps_raw_to(msg: p.GpsRawInt) -> Wire:
    return wire(
        mav.MAVLink_gps_raw_int_message,
        round(msg.time_boot_s * 1e6),
        msg.fix_type,
        round(msg.lat_deg * 1e7),
        round(msg.lon_deg * 1e7),
        round(msg.alt_msl_m * 1e3),
        round(msg.hdop * 100.0),
        round(msg.vdop * 100.0),
        round(msg.ground_speed_m_s * 100.0),
        round(msg.course_deg * 100.0) % 36000,
        msg.satellites_visible,
    )


def _gps_raw_from(raw: Any) -> p.GpsRawInt:
    return p.GpsRawInt(
        raw.time_usec / 1e6,
        raw.fix_type,
        raw.lat / 1e7,
        raw.lon / 1e7,
        raw.alt / 1e3,
        raw.eph / 100.0,
        raw.epv / 100.0,
        raw.vel / 100.0,
        raw.cog / 100.0,
        raw.satellites_visible,
    )


def _vfr_hud_to(msg: p.VfrHud) -> Wire:
    return wire(
        mav.MAVLink_vfr_hud_message,
        msg.airspeed_m_s,
        msg.groundspeed_m_s,
        msg.heading_deg,
        msg.throttle_pct,
        msg.alt_msl_m,
        msg.climb_m_s,
    )


def _vfr_hud_from(raw: Any) -> p.VfrHud:
    check_finite("VFR_HUD", raw.airspeed, raw.groundspeed, raw.alt, raw.climb)
    return p.VfrHud(
        float(raw.airspeed),
        float(raw.groundspeed),
        raw.heading,
        raw.throttle,
        float(raw.alt),
        float(raw.climb),
    )


def _battery_to(msg: p.BatteryStatus) -> Wire:
    cells = [round(msg.voltage_v * 1e3)] + [65535] * 9
    return wire(
        mav.MAVLink_battery_status_message,
        0,
        0,
        0,
        32767,
        cells,
        round(msg.current_a * 100.0),
        -1,
        -1,
        msg.remaining_pct,
    )


def _battery_from(raw: Any) -> p.BatteryStatus:
    return p.BatteryStatus(
        raw.voltages[0] / 1e3, raw.current_battery / 100.0, raw.battery_remaining
    )


def _rc_to(msg: p.RcChannels) -> Wire:
    channels = (tuple(msg.channels_us) + (0,) * 18)[:18]
    return wire(
        mav.MAVLink_rc_channels_message,
        ms(msg.time_boot_s),
        msg.channel_count,
        *channels,
        msg.rssi,
    )


def _rc_from(raw: Any) -> p.RcChannels:
    channels = tuple(getattr(raw, f"chan{k}_raw") for k in range(1, 19))
    return p.RcChannels(raw.time_boot_ms / 1000.0, raw.chancount, channels, raw.rssi)


def _timesync_to(msg: p.Timesync) -> Wire:
    return wire(mav.MAVLink_timesync_message, msg.tc1_ns, msg.ts1_ns)


def _timesync_from(raw: Any) -> p.Timesync:
    return p.Timesync(raw.tc1, raw.ts1)


def _rds_to(msg: p.RequestDataStream) -> Wire:
    return wire(
        mav.MAVLink_request_data_stream_message,
        msg.target_system,
        msg.target_component,
        msg.stream_id,
        msg.rate_hz,
        int(msg.start),
    )


def _rds_from(raw: Any) -> p.RequestDataStream:
    return p.RequestDataStream(
        raw.target_system,
        raw.target_component,
        raw.req_stream_id,
        raw.req_message_rate,
        bool(raw.start_stop),
    )


def _addressed_to(cls: Any) -> Any:
    def to(msg: Any) -> Wire:
        return wire(cls, msg.target_system, msg.target_component, msg.mission_type)

    return to


def _mission_request_list_from(raw: Any) -> p.MissionRequestList:
    return p.MissionRequestList(raw.target_system, raw.target_component, raw.mission_type)


def _mission_clear_all_from(raw: Any) -> p.MissionClearAll:
    return p.MissionClearAll(raw.target_system, raw.target_component, raw.mission_type)


def _mission_count_to(msg: p.MissionCount) -> Wire:
    return wire(
        mav.MAVLink_mission_count_message,
        msg.target_system,
        msg.target_component,
        msg.count,
        msg.mission_type,
    )


def _mission_count_from(raw: Any) -> p.MissionCount:
    return p.MissionCount(raw.target_system, raw.target_component, raw.count, raw.mission_type)


def _request_to(cls: Any) -> Any:
    def to(msg: p.MissionRequestInt | p.MissionRequest) -> Wire:
        return wire(cls, msg.target_system, msg.target_component, msg.seq, msg.mission_type)

    return to


def _request_int_from(raw: Any) -> p.MissionRequestInt:
    return p.MissionRequestInt(raw.target_system, raw.target_component, raw.seq, raw.mission_type)


def _request_from(raw: Any) -> p.MissionRequest:
    return p.MissionRequest(raw.target_system, raw.target_component, raw.seq, raw.mission_type)


def _item_int_to(msg: p.MissionItemInt) -> Wire:
    x, y = _xy_to_int(msg.frame, msg.params[4], msg.params[5])
    return _item_wire(mav.MAVLink_mission_item_int_message, msg, x, y)


def _item_to(msg: p.MissionItem) -> Wire:
    return _item_wire(mav.MAVLink_mission_item_message, msg, msg.params[4], msg.params[5])


def _item_wire(cls: Any, msg: p.MissionItemInt | p.MissionItem, x: float, y: float) -> Wire:
    return wire(
        cls,
        msg.target_system,
        msg.target_component,
        msg.seq,
        msg.frame,
        msg.command,
        msg.current,
        msg.autocontinue,
        *msg.params[:4],
        x,
        y,
        msg.params[6],
        msg.mission_type,
    )


def _item_int_from(raw: Any) -> p.MissionItemInt:
    x, y = _xy_from_int(raw.frame, raw.x, raw.y)
    return p.MissionItemInt(*_item_fields(raw, x, y))


def _item_from(raw: Any) -> p.MissionItem:
    return p.MissionItem(*_item_fields(raw, raw.x, raw.y))


def _item_fields(raw: Any, x: float, y: float) -> tuple[Any, ...]:
    params = _params_from(raw, x, y)
    if raw.frame in GLOBAL_FRAMES and not (abs(params[4]) <= 90.0 and abs(params[5]) <= 180.0):
        raise WireError(f"MISSION_ITEM: latitude {params[4]} / longitude {params[5]} out of range")
    return (
        raw.target_system,
        raw.target_component,
        raw.seq,
        raw.frame,
        raw.command,
        raw.current,
        raw.autocontinue,
        params,
        raw.mission_type,
    )


def _mission_ack_to(msg: p.MissionAck) -> Wire:
    return wire(
        mav.MAVLink_mission_ack_message,
        msg.target_system,
        msg.target_component,
        msg.result,
        msg.mission_type,
    )


def _mission_ack_from(raw: Any) -> p.MissionAck:
    return p.MissionAck(raw.target_system, raw.target_component, raw.type, raw.mission_type)


def _set_current_to(msg: p.MissionSetCurrent) -> Wire:
    return wire(
        mav.MAVLink_mission_set_current_message, msg.target_system, msg.target_component, msg.seq
    )


def _set_current_from(raw: Any) -> p.MissionSetCurrent:
    return p.MissionSetCurrent(raw.target_system, raw.target_component, raw.seq)


def _current_to(msg: p.MissionCurrent) -> Wire:
    return wire(mav.MAVLink_mission_current_message, msg.seq, msg.total)


def _current_from(raw: Any) -> p.MissionCurrent:
    return p.MissionCurrent(raw.seq, raw.total)


def _reached_to(msg: p.MissionItemReached) -> Wire:
    return wire(mav.MAVLink_mission_item_reached_message, msg.seq)


def _reached_from(raw: Any) -> p.MissionItemReached:
    return p.MissionItemReached(raw.seq)


FTP_PAYLOAD_LEN = 251


def _ftp_to(msg: p.FileTransferProtocol) -> Wire:
    payload = list(msg.payload.ljust(FTP_PAYLOAD_LEN, b"\0")[:FTP_PAYLOAD_LEN])
    return wire(
        mav.MAVLink_file_transfer_protocol_message,
        msg.target_network,
        msg.target_system,
        msg.target_component,
        payload,
    )


def _ftp_from(raw: Any) -> p.FileTransferProtocol:
    return p.FileTransferProtocol(
        raw.target_network, raw.target_system, raw.target_component, bytes(raw.payload)
    )


CODECS: CodecTable = {
    p.CommandInt: ("COMMAND_INT", _command_int_to, _command_int_from),
    p.ParamRequestList: (
        "PARAM_REQUEST_LIST",
        _param_request_list_to,
        _param_request_list_from,
    ),
    p.ParamRequestRead: (
        "PARAM_REQUEST_READ",
        _param_request_read_to,
        _param_request_read_from,
    ),
    p.ParamSet: ("PARAM_SET", _param_set_to, _param_set_from),
    p.ParamValue: ("PARAM_VALUE", _param_value_to, _param_value_from),
    p.AutopilotVersion: ("AUTOPILOT_VERSION", _autopilot_version_to, _autopilot_version_from),
    p.ExtendedSysState: ("EXTENDED_SYS_STATE", _ess_to, _ess_from),
    p.GpsRawInt: ("GPS_RAW_INT", _gps_raw_to, _gps_raw_from),
    p.VfrHud: ("VFR_HUD", _vfr_hud_to, _vfr_hud_from),
    p.BatteryStatus: ("BATTERY_STATUS", _battery_to, _battery_from),
    p.RcChannels: ("RC_CHANNELS", _rc_to, _rc_from),
    p.Timesync: ("TIMESYNC", _timesync_to, _timesync_from),
    p.RequestDataStream: ("REQUEST_DATA_STREAM", _rds_to, _rds_from),
    p.MissionRequestList: (
        "MISSION_REQUEST_LIST",
        _addressed_to(mav.MAVLink_mission_request_list_message),
        _mission_request_list_from,
    ),
    p.MissionClearAll: (
        "MISSION_CLEAR_ALL",
        _addressed_to(mav.MAVLink_mission_clear_all_message),
        _mission_clear_all_from,
    ),
    p.MissionCount: ("MISSION_COUNT", _mission_count_to, _mission_count_from),
    p.MissionRequestInt: (
        "MISSION_REQUEST_INT",
        _request_to(mav.MAVLink_mission_request_int_message),
        _request_int_from,
    ),
    p.MissionRequest: (
        "MISSION_REQUEST",
        _request_to(mav.MAVLink_mission_request_message),
        _request_from,
    ),
    p.MissionItemInt: ("MISSION_ITEM_INT", _item_int_to, _item_int_from),
    p.MissionItem: ("MISSION_ITEM", _item_to, _item_from),
    p.MissionAck: ("MISSION_ACK", _mission_ack_to, _mission_ack_from),
    p.MissionSetCurrent: ("MISSION_SET_CURRENT", _set_current_to, _set_current_from),
    p.MissionCurrent: ("MISSION_CURRENT", _current_to, _current_from),
    p.MissionItemReached: ("MISSION_ITEM_REACHED", _reached_to, _reached_from),
    p.FileTransferProtocol: ("FILE_TRANSFER_PROTOCOL", _ftp_to, _ftp_from),
}
