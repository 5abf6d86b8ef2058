"""The sim autopilot's geofence (FENCE_*): a ground station sets it over real UDP, flies out of
it and sees ArduCopter's answer (STATUSTEXT, FENCE_ACTION's mode, the SYS_STATUS health bit);
the other fences and actions in memory (``SimPair``)."""

from __future__ import annotations

import os
import time
from typing import Any

import pytest

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.messages import CopterMode, MavCmd
from ridsafe.common.protocol_messages import MissionType
from ridsafe.sim_backend.fence import CIRCLE_INCLUSION, POLYGON_VERTEX_INCLUSION
from ridsafe.sim_backend.mission_protocol import StoredItem
from tests.sim_backend.helpers import SimPair
from tests.sim_backend.udp_sim import sim_on_udp

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

GCS_BASE, COMPANION_BASE = 26450, 27660
GEOFENCE = 0x100000  # MAV_SYS_STATUS_GEOFENCE
mav = mavutil.mavlink


class Station:
    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
        assert self.conn.wait_heartbeat(timeout=30) is not None
        self.texts: list[str] = []

    def wait(self, kind: str, timeout_s: float, **match: Any) -> Any:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            msg = self.conn.recv_match(blocking=True, timeout=0.5)
            if msg is None:
                continue
            if msg.get_type() == "STATUSTEXT":
                self.texts.append(msg.text)
            if msg.get_type() == kind and all(getattr(msg, k) == v for k, v in match.items()):
                return msg
        raise AssertionError(f"no {kind} {match} in {timeout_s} s; texts {self.texts}")

    def command(self, command: int, *params: float) -> None:
        p = (*params, *(0.0,) * 7)[:7]
        self.conn.mav.command_long_send(self.conn.target_system, 1, command, 0, *p)
        ack = self.wait("COMMAND_ACK", 10.0, command=command)
        assert ack.result == mav.MAV_RESULT_ACCEPTED, ack

    def set_param(self, name: str, value: float) -> None:
        self.conn.mav.param_set_send(self.conn.target_system, 1, name.encode(), value,
                                     mav.MAV_PARAM_TYPE_REAL32)  # fmt: skip
        assert self.wait("PARAM_VALUE", 5.0, param_id=name).param_value == value

    def height_m(self) -> float:
        return float(self.wait("GLOBAL_POSITION_INT", 5.0).relative_alt) / 1000.0


@pytest.mark.udp
def test_a_station_flies_out_of_the_circle_fence_and_the_vehicle_lands() -> None:
    with sim_on_udp(GCS_BASE, COMPANION_BASE, speed=4.0):
        station = Station(GCS_BASE)
        for msg_id in (mav.MAVLINK_MSG_ID_SYS_STATUS, mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT):
            station.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000)
        for name, value in (("FENCE_ENABLE", 1), ("FENCE_TYPE", 2), ("FENCE_RADIUS", 40),
                            ("FENCE_ACTION", 2)):  # fmt: skip
            station.set_param(name, value)
        status = station.wait("SYS_STATUS", 5.0)
        assert status.onboard_control_sensors_enabled & GEOFENCE
        assert status.onboard_control_sensors_health & GEOFENCE
        station.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                        CopterMode.GUIDED)  # fmt: skip
        station.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        station.command(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)
        deadline = time.monotonic() + 30
        while station.height_m() < 9.0:
            assert time.monotonic() < deadline, "no take-off"
        station.conn.mav.set_position_target_local_ned_send(
            0, station.conn.target_system, 1, mav.MAV_FRAME_LOCAL_NED, 0b110111111000,
            80, 0, -10, 0, 0, 0, 0, 0, 0, 0, 0,
        )  # fmt: skip
        station.wait("HEARTBEAT", 30.0, custom_mode=int(CopterMode.LAND))
        assert any(text.startswith("Fence Breach: circle") for text in station.texts)
        breached = station.wait("SYS_STATUS", 5.0)
        assert breached.onboard_control_sensors_present & GEOFENCE
        assert not breached.onboard_control_sensors_health & GEOFENCE


# --- in memory ---------------------------------------------------------------------------------


def flying(pair: SimPair, alt_m: float = 10.0) -> None:
    pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED)
    pair.command(MavCmd.COMPONENT_ARM_DISARM, 1)
    pair.command(MavCmd.NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m)
    pair.run(12.0)


def set_params(pair: SimPair, **values: float) -> None:
    pair.step([pm.ParamSet(1, 1, name, value, int(pm.ParamType.REAL32))
               for name, value in values.items()])  # fmt: skip


def go_to(pair: SimPair, north_m: float, east_m: float, up_m: float) -> None:
    pair.step([m.SetPositionTargetLocalNed(0.0, 1, 1, m.MavFrame.LOCAL_NED, 0b110111111000,
                                           (north_m, east_m, -up_m), (0.0, 0.0, 0.0),
                                           (0.0, 0.0, 0.0), 0.0, 0.0)])  # fmt: skip


def texts(pair: SimPair) -> list[str]:
    return [r.message.text for r in pair.received if isinstance(r.message, m.StatusText)]


@pytest.fixture
def pair() -> SimPair:
    p = SimPair(dt_s=0.05)
    p.run(0.5)
    return p


def test_the_altitude_fence_sends_the_vehicle_home(pair: SimPair) -> None:
    set_params(pair, FENCE_ENABLE=1, FENCE_TYPE=1, FENCE_ALT_MAX=15, FENCE_ACTION=1)
    flying(pair)
    go_to(pair, 0, 0, 25)
    pair.run(15.0)
    autopilot = pair.backend.autopilots[0]
    assert autopilot.mode in (CopterMode.RTL, CopterMode.LAND)
    assert any(text.startswith("Fence Breach: altitude; RTL_OR_LAND") for text in texts(pair))
    assert autopilot.fence.breaches == 1


def test_an_uploaded_polygon_is_a_fence_and_report_only_changes_no_mode(pair: SimPair) -> None:
    home = pair.backend.homes[0].home_geodetic
    deg_per_m = 1.0 / 111_120.0
    corners = [(-20, -20), (-20, 20), (30, 20), (30, -20)]  # north, east (m)
    items = [StoredItem(0, POLYGON_VERTEX_INCLUSION, 0,
                        (4.0, 0, 0, 0, home.lat_deg + n * deg_per_m,
                         home.lon_deg + e * deg_per_m / 0.8, 0))
             for n, e in corners]  # fmt: skip
    pair.backend.autopilots[0].missions.lists[MissionType.FENCE] = items
    set_params(pair, FENCE_ENABLE=1, FENCE_TYPE=4, FENCE_ACTION=0)
    flying(pair)
    assert pair.backend.autopilots[0].fence.healthy()  # inside
    go_to(pair, 60, 0, 10)
    pair.run(15.0)
    autopilot = pair.backend.autopilots[0]
    assert autopilot.mode is CopterMode.GUIDED  # report only
    assert any(text.startswith("Fence Breach: polygon") for text in texts(pair))
    assert not autopilot.fence.healthy()
    go_to(pair, 0, 0, 10)
    pair.run(15.0)
    assert autopilot.fence.healthy() and "Fence breach cleared" in texts(pair)


def test_an_inclusion_circle_item_and_brake(pair: SimPair) -> None:
    home = pair.backend.homes[0].home_geodetic
    circle = StoredItem(0, CIRCLE_INCLUSION, 0, (30.0, 0, 0, 0, home.lat_deg, home.lon_deg, 0))
    pair.backend.autopilots[0].missions.lists[MissionType.FENCE] = [circle]
    set_params(pair, FENCE_ENABLE=1, FENCE_TYPE=4, FENCE_ACTION=4)
    flying(pair)
    go_to(pair, 0, 80, 10)
    pair.run(15.0)
    assert pair.backend.autopilots[0].mode is CopterMode.BRAKE


def test_with_fence_enable_0_nothing_is_checked(pair: SimPair) -> None:
    set_params(pair, FENCE_RADIUS=30)
    flying(pair)
    go_to(pair, 60, 0, 10)
    pair.run(15.0)
    assert pair.backend.autopilots[0].mode is CopterMode.GUIDED
    assert not any("Fence" in text for text in texts(pair))
