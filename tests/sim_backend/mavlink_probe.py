"""The questions a QGroundControl-style ground station asks an autopilot at connect, as plain
pymavlink, and what came back, reduced to what must match between the sim and ArduCopter."""

from __future__ import annotations

import os
import struct
import time
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

mav = mavutil.mavlink
STREAMED = {
    "GPS_RAW_INT": mav.MAVLINK_MSG_ID_GPS_RAW_INT,
    "VFR_HUD": mav.MAVLINK_MSG_ID_VFR_HUD,
    "EXTENDED_SYS_STATE": mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
    "BATTERY_STATUS": mav.MAVLINK_MSG_ID_BATTERY_STATUS,
    "RC_CHANNELS": mav.MAVLINK_MSG_ID_RC_CHANNELS,
}


class Probe:
    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=255, source_component=190
        )

    def close(self) -> None:
        self.conn.close()

    def heartbeat(self, timeout_s: float = 30.0) -> Any:
        return self.conn.wait_heartbeat(timeout=timeout_s)

    def wait(self, kind: str, timeout_s: float = 5.0, **match: Any) -> Any:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            msg = self.conn.recv_match(type=kind, blocking=True, timeout=0.5)
            if msg is not None and all(getattr(msg, k) == v for k, v in match.items()):
                return msg
        return None

    def guided_waypoint(self, lat_e7: int, lon_e7: int, alt_m: float) -> int | None:
        """MISSION_ITEM_INT current=2 (fly there in GUIDED): the MISSION_ACK type, or None.
        Resent while unanswered, as a client does under the mission protocol."""
        for _ in range(3):
            self.conn.mav.mission_item_int_send(
                self.conn.target_system, 1, 0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 16, 2, 0,
                0, 0, 0, 0, lat_e7, lon_e7, alt_m, 0,
            )  # fmt: skip
            ack = self.wait("MISSION_ACK")
            if ack is not None:
                return int(ack.type)
        return None

    def ack(self, command: int, timeout_s: float = 5.0) -> int | None:
        msg = self.wait("COMMAND_ACK", timeout_s, command=command)
        return None if msg is None else int(msg.result)

    def command_long(self, command: int, *params: float) -> int | None:
        p = (tuple(params) + (0.0,) * 7)[:7]
        self.conn.mav.command_long_send(self.conn.target_system, 1, command, 0, *p)
        return self.ack(command)

    def count_params(self, window_s: float = 10.0) -> int:
        self.conn.mav.param_request_list_send(self.conn.target_system, 1)
        names: set[str] = set()
        deadline = time.monotonic() + window_s
        while time.monotonic() < deadline:
            msg = self.conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
            if msg is None:
                if names:
                    break
                continue
            names.add(msg.param_id)
            if len(names) >= msg.param_count:
                break
        return len(names)

    def ftp_open_params(self) -> str | None:
        """MAVLink FTP OpenFileRO of ``@PARAM/param.pck`` (then TerminateSession): "ACK" with a
        size, else the NAK's error code, None without an answer."""
        path = b"@PARAM/param.pck"
        header = struct.pack("<HBBBBBBI", 1, 0, 4, len(path), 0, 0, 0, 0)  # OpenFileRO
        payload = list((header + path).ljust(251, b"\0"))
        self.conn.mav.file_transfer_protocol_send(0, self.conn.target_system, 1, payload)
        reply = self.wait("FILE_TRANSFER_PROTOCOL", 10.0)
        if reply is None:
            return None
        _seq, _session, opcode, size, req_opcode = struct.unpack_from(
            "<HBBBB", bytes(reply.payload)
        )
        data = bytes(reply.payload[12 : 12 + size])
        end = struct.pack("<HBBBBBBI", 2, 0, 1, 0, 0, 0, 0, 0)  # TerminateSession
        self.conn.mav.file_transfer_protocol_send(0, self.conn.target_system, 1,
                                                  list(end.ljust(251, b"\0")))  # fmt: skip
        if opcode == 128 and req_opcode == 4 and size == 4:
            return "ACK" if struct.unpack("<I", data)[0] > 6 else "ACK empty"
        return f"NAK {data[:1].hex()}"

    def mission_count(self, mission_type: int) -> int | None:
        self.conn.mav.mission_request_list_send(self.conn.target_system, 1, mission_type)
        msg = self.wait("MISSION_COUNT", mission_type=mission_type)
        return None if msg is None else int(msg.count)


def ask(port: int, ready_text: str | None = None, ready_timeout_s: float = 120.0) -> dict[str, Any]:
    """Every answer, keyed by question; first waits for a STATUSTEXT containing
    ``ready_text`` (a real ArduCopter: its position estimate) if given."""
    probe = Probe(port)
    try:
        hb = probe.heartbeat()
        if ready_text is not None:
            deadline = time.monotonic() + ready_timeout_s
            while time.monotonic() < deadline:
                # ArduPilot sends STATUSTEXT only on links it has heard from: say we are here
                probe.conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                text = probe.wait("STATUSTEXT", 1.0)
                if text is not None and ready_text in text.text:
                    break
        answers: dict[str, Any] = {"autopilot": hb.autopilot}
        answers["params"] = probe.count_params()
        probe.conn.mav.param_request_read_send(probe.conn.target_system, 1, b"RTL_ALT", -1)
        value = probe.wait("PARAM_VALUE", param_id="RTL_ALT")
        answers["RTL_ALT"] = None if value is None else value.param_value
        for name, kind in (("mission", 0), ("fence", 1), ("rally", 2)):
            answers[f"count {name}"] = probe.mission_count(kind)
        version_id = mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION
        answers["request AUTOPILOT_VERSION"] = probe.command_long(512, version_id)
        answers["AUTOPILOT_VERSION"] = probe.wait("AUTOPILOT_VERSION") is not None
        answers["cmd 520"] = probe.command_long(520, 1)
        answers["cmd 410"] = probe.command_long(410)
        for name, msg_id in STREAMED.items():
            answers[f"interval {name}"] = probe.command_long(511, msg_id, 200_000)
            answers[f"streamed {name}"] = probe.wait(name) is not None
        probe.conn.mav.request_data_stream_send(probe.conn.target_system, 1, 6, 4, 1)
        answers["data stream POSITION"] = probe.wait("GLOBAL_POSITION_INT") is not None
        probe.conn.mav.timesync_send(0, 123456789)
        sync = probe.wait("TIMESYNC", ts1=123456789)
        answers["TIMESYNC"] = sync is not None and sync.tc1 != 0
        answers["FTP open @PARAM/param.pck"] = probe.ftp_open_params()
        probe.command_long(511, mav.MAVLINK_MSG_ID_SYS_STATUS, 500_000)
        status = probe.wait("SYS_STATUS", 10.0)
        prearm = mav.MAV_SYS_STATUS_PREARM_CHECK
        answers["prearm bit"] = status is not None and bool(
            status.onboard_control_sensors_present & prearm
        )
        probe.conn.mav.command_int_send(probe.conn.target_system, 1, 0, 176, 0, 0,
                                        1, 4, 0, 0, 0, 0, 0)  # fmt: skip
        answers["COMMAND_INT set GUIDED"] = probe.ack(176)
        deadline = time.monotonic() + 60.0
        while probe.command_long(400, 1) != 0 and time.monotonic() < deadline:  # arm
            time.sleep(1.0)
        probe.command_long(22, 0, 0, 0, 0, 0, 0, 10.0)  # take off to 10 m
        time.sleep(3.0)
        here = probe.wait("GLOBAL_POSITION_INT")
        answers["guided MISSION_ITEM_INT"] = probe.guided_waypoint(here.lat + 200, here.lon, 12.0)
        probe.conn.mav.command_int_send(
            probe.conn.target_system, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 192, 0, 0,
            -1, 1, 0, 0, here.lat, here.lon + 200, 12.0,
        )  # fmt: skip
        answers["COMMAND_INT DO_REPOSITION"] = probe.ack(192)
        probe.command_long(21)  # land
        return answers
    finally:
        probe.close()
