"""Parameters, missions, AUTO, COMMAND_INT, data streams and TIMESYNC of the sim autopilot,
over real MAVLink bytes in memory (``SimPair``)."""

from __future__ import annotations

import math

import pytest

from ridsafe.common import messages as m
from ridsafe.common import protocol_messages as pm
from ridsafe.common.messages import CopterMode, MavCmd
from ridsafe.common.protocol_messages import MissionResult, MissionType
from ridsafe.sim_backend.autopilot import AutopilotConfig
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.param_table import PARAMS
from ridsafe.sim_backend.telemetry import GPS_RAW_INT, VFR_HUD
from ridsafe.sim_backend.world import SimBackend
from tests.sim_backend.helpers import SimPair, scenario

GLOBAL_RELATIVE_ALT = 3


def _got(pair: SimPair, kind: type, since: int = 0) -> list[m.Message]:
    return [r.message for r in pair.received[since:] if isinstance(r.message, kind)]


@pytest.fixture
def pair() -> SimPair:
    p = SimPair()
    p.run(0.5)
    return p


def _north_of_home(pair: SimPair, north_m: float) -> tuple[float, float]:
    home = pair.backend.homes[0].home_geodetic
    return home.lat_deg + north_m / 111_120.0, home.lon_deg


# --- parameters ------------------------------------------------------------------------------


def test_param_list_returns_every_row_once_in_table_order(pair: SimPair) -> None:
    start = len(pair.received)
    pair.step([pm.ParamRequestList(1, 1)])
    values = _got(pair, pm.ParamValue, start)
    assert [v.param_id for v in values] == [spec.name for spec in PARAMS]  # type: ignore[union-attr]
    assert all(v.param_count == len(PARAMS) for v in values)  # type: ignore[union-attr]


def test_param_read_by_name_and_index_and_unknown_names_get_no_answer(pair: SimPair) -> None:
    start = len(pair.received)
    pair.step([pm.ParamRequestRead(1, 1, "RTL_ALT", -1), pm.ParamRequestRead(1, 1, "", 0),
               pm.ParamRequestRead(1, 1, "NO_SUCH_PARAM", -1)])  # fmt: skip
    values = _got(pair, pm.ParamValue, start)
    assert [(v.param_id, v.value) for v in values] == [  # type: ignore[union-attr]
        ("RTL_ALT", 1500.0), (PARAMS[0].name, 1.0)]  # fmt: skip


def test_param_set_clips_and_changes_behaviour(pair: SimPair) -> None:
    start = len(pair.received)
    pair.step([pm.ParamSet(1, 1, "RTL_ALT", 99_999_999.0, 9)])
    (echo,) = _got(pair, pm.ParamValue, start)
    assert echo.value == 300000.0  # type: ignore[union-attr]
    pair.step([pm.ParamSet(1, 1, "RTL_ALT", 3000.0, 9)])  # 30 m
    pair.take_off(10.0)
    lat, lon = _north_of_home(pair, 40.0)
    pair.step([pm.MissionItemInt(1, 1, 0, GLOBAL_RELATIVE_ALT, 16, 2, 0,
                                 (0, 0, 0, 0, lat, lon, 10.0), 0)])  # fmt: skip
    pair.run(12.0)
    assert pair.command(MavCmd.NAV_RETURN_TO_LAUNCH).result == 0
    pair.run(12.0)  # RTL climbs to RTL_ALT (now 30 m) before it turns home
    assert pair.altitude_m() > 25.0


def test_arming_check_zero_skips_the_prearm_period() -> None:
    config = SimConfig(autopilot=AutopilotConfig(prearm_delay_s=60.0))
    pair = SimPair(SimBackend(scenario(), config))
    pair.run(0.5)
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED).result == 0
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == m.MavResult.FAILED
    assert "Arm: Need Position Estimate" in pair.texts()
    pair.step([pm.ParamSet(1, 1, "ARMING_CHECK", 0.0, 2)])
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == 0


# --- streams and time ----------------------------------------------------------------------


def test_request_data_stream_and_sr_parameters_start_and_stop_groups(pair: SimPair) -> None:
    assert not _got(pair, pm.GpsRawInt)
    pair.step([pm.RequestDataStream(1, 1, 2, 5, True)])  # EXTENDED_STATUS
    start = len(pair.received)
    pair.run(2.0)
    assert 8 <= len(_got(pair, pm.GpsRawInt, start)) <= 11
    pair.step([pm.ParamSet(1, 1, "SR0_EXTRA2", 2.0, 4)])  # this link is serial 0
    start = len(pair.received)
    pair.run(2.0)
    assert 3 <= len(_got(pair, pm.VfrHud, start)) <= 5
    pair.step([pm.RequestDataStream(1, 1, 0, 0, False)])  # everything off
    start = len(pair.received)
    pair.run(2.0)
    assert not _got(pair, pm.GpsRawInt, start) and not _got(pair, pm.VfrHud, start)
    assert {GPS_RAW_INT, VFR_HUD} <= set(pair.backend.endpoints["v1/gcs"].schedule.interval_s)


def test_timesync_request_is_answered_with_the_vehicle_clock(pair: SimPair) -> None:
    start = len(pair.received)
    pair.step([pm.Timesync(0, 42)])
    (answer,) = _got(pair, pm.Timesync, start)
    assert answer.ts1_ns == 42  # type: ignore[union-attr]
    assert answer.tc1_ns == pytest.approx(pair.t_s * 1e9, abs=0.05e9)  # type: ignore[union-attr]


# --- missions ------------------------------------------------------------------------------


def _item(seq: int, command: int, lat: float, lon: float, alt: float) -> pm.MissionItemInt:
    return pm.MissionItemInt(1, 1, seq, GLOBAL_RELATIVE_ALT, command, 0, 1,
                             (0, 0, 0, 0, lat, lon, alt), MissionType.MISSION)  # fmt: skip


def _upload(pair: SimPair, items: list[pm.MissionItemInt]) -> None:
    start = len(pair.received)
    pair.step([pm.MissionCount(1, 1, len(items), MissionType.MISSION)])
    for item in items:
        (request,) = _got(pair, pm.MissionRequestInt, start)
        assert request.seq == item.seq  # type: ignore[union-attr]
        start = len(pair.received)
        pair.step([item])
    (ack,) = _got(pair, pm.MissionAck, start)
    assert ack.result == MissionResult.ACCEPTED  # type: ignore[union-attr]


def test_upload_then_download_round_trips_and_item_0_is_home(pair: SimPair) -> None:
    lat, lon = _north_of_home(pair, 40.0)
    items = [_item(0, 16, 0, 0, 0), _item(1, 22, 0, 0, 15), _item(2, 16, lat, lon, 15),
             _item(3, 21, 0, 0, 0)]  # fmt: skip
    _upload(pair, items)
    start = len(pair.received)
    pair.step([pm.MissionRequestList(1, 1, MissionType.MISSION)])
    (count,) = _got(pair, pm.MissionCount, start)
    assert count.count == 4  # type: ignore[union-attr]
    pair.step([pm.MissionRequestInt(1, 1, 0, 0), pm.MissionRequestInt(1, 1, 2, 0)])
    home, wp = _got(pair, pm.MissionItemInt, start)
    assert home.params[4] == pytest.approx(pair.backend.homes[0].home_geodetic.lat_deg)  # type: ignore[union-attr]
    assert wp.params[4:6] == pytest.approx((lat, lon)) and wp.command == 16  # type: ignore[union-attr]
    pair.step([pm.MissionRequestList(1, 1, MissionType.FENCE)])
    pair.step([pm.MissionRequestInt(1, 1, 9, 0)])
    fence, _ = _got(pair, pm.MissionCount, start)[1], None
    assert fence.count == 0  # type: ignore[union-attr]
    assert _got(pair, pm.MissionAck, start)[-1].result == MissionResult.INVALID_SEQUENCE  # type: ignore[union-attr]


def test_auto_flies_takeoff_waypoint_and_land_then_disarms(pair: SimPair) -> None:
    lat, lon = _north_of_home(pair, 40.0)
    _upload(pair, [_item(0, 16, 0, 0, 0), _item(1, 22, 0, 0, 15), _item(2, 16, lat, lon, 15),
                   _item(3, 21, 0, 0, 0)])  # fmt: skip
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.GUIDED).result == 0
    assert pair.command(MavCmd.COMPONENT_ARM_DISARM, 1).result == 0
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.AUTO).result == 0
    heights = []
    for _ in range(75):
        pair.run(1.0)
        heights.append(pair.altitude_m())
    assert 14.0 < max(heights) < 16.0  # NAV_TAKEOFF to 15 m, the waypoint at 15 m
    assert not pair.backend.truth().armed[0]  # NAV_LAND landed and disarmed
    north, east, _ = pair.backend.homes[0].enu_to_local_ned(pair.position_enu())
    assert math.hypot(north - 40.0, east) < 2.5  # within WPNAV_RADIUS (2 m), landed there


def test_auto_without_a_mission_is_refused(pair: SimPair) -> None:
    assert pair.command(MavCmd.DO_SET_MODE, 1, CopterMode.AUTO).result == m.MavResult.FAILED


# --- guided targets by global position --------------------------------------------------------


def test_guided_mission_item_and_do_reposition_move_the_vehicle(pair: SimPair) -> None:
    pair.take_off(10.0)
    lat, lon = _north_of_home(pair, 30.0)
    start = len(pair.received)
    guided = pm.MissionItemInt(1, 1, 0, GLOBAL_RELATIVE_ALT, 16, 2, 0,
                               (0, 0, 0, 0, lat, lon, 12.0), 0)  # fmt: skip
    pair.step([guided])
    (ack,) = _got(pair, pm.MissionAck, start)
    assert ack.result == MissionResult.ACCEPTED  # type: ignore[union-attr]
    pair.run(15.0)
    north, _, down = pair.backend.homes[0].enu_to_local_ned(pair.position_enu())
    assert north == pytest.approx(30.0, abs=1.0) and -down == pytest.approx(12.0, abs=0.5)
    start = len(pair.received)
    pair.step(
        [
            pm.CommandInt(
                1,
                1,
                GLOBAL_RELATIVE_ALT,
                192,
                0,
                0,
                (-1, 1, 0, 0, *_north_of_home(pair, 0.0), 12.0),
            )
        ]
    )
    (ack2,) = _got(pair, m.CommandAck, start)
    assert ack2.command == 192 and ack2.result == 0  # type: ignore[union-attr]
    pair.run(15.0)
    north, _, _ = pair.backend.homes[0].enu_to_local_ned(pair.position_enu())
    assert abs(north) < 1.0


def test_do_reposition_as_command_long_is_unsupported(pair: SimPair) -> None:
    assert pair.command(192, -1, 1, 0, 0, 36.0, -86.0, 10).result == m.MavResult.UNSUPPORTED
