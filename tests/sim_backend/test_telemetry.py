"""Autopilot telemetry: stream scheduling (SET_MESSAGE_INTERVAL semantics) and sim truth ->
MAVLink conversion (scenario ENU / body FLU -> WGS-84, local NED at home, body FRD).

Oracles: message counts over 10 s of 0.01 s ticks; NED positions through the geodetic path
(``frames.geodetic_to_ned`` about the home, independent of HomeFrame's linear map); heading from
the body's forward axis; attitude from rotation matrices built with scipy (R_ned_frd =
T R_enu_flu D) rather than from the conversion formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ridsafe.common import frames
from ridsafe.common import messages as m
from ridsafe.sim_backend.autopilot import HomeFrame
from ridsafe.sim_backend.dynamics import BODY_RATES, EULER, POS_ENU, STATE_SIZE, VEL_ENU
from ridsafe.sim_backend.telemetry import (
    ATTITUDE,
    GLOBAL_POSITION_INT,
    HEARTBEAT,
    HOME_POSITION,
    LOCAL_POSITION_NED,
    SYS_STATUS,
    SYSTEM_TIME,
    FleetSnapshot,
    TelemetryRatesHz,
    TelemetrySchedule,
)

FloatArray = NDArray[np.float64]

TICKS = [i / 100.0 for i in range(1000)]  # 10 s of 0.01 s ticks


def _run(schedule: TelemetrySchedule, ticks: list[float]) -> dict[int, list[float]]:
    sent: dict[int, list[float]] = {}
    for t in ticks:
        for msg_id in schedule.due(t):
            sent.setdefault(msg_id, []).append(t)
    return sent


# --- TelemetrySchedule -----------------------------------------------------------------------


def test_message_ids_are_the_common_xml_ones() -> None:
    ids = (HEARTBEAT, SYS_STATUS, SYSTEM_TIME, ATTITUDE, LOCAL_POSITION_NED)
    assert ids == (0, 1, 2, 30, 32)
    assert (GLOBAL_POSITION_INT, HOME_POSITION) == (33, 242)


def test_default_rates_give_the_right_number_of_messages() -> None:
    sent = _run(TelemetrySchedule(TelemetryRatesHz().by_id()), TICKS)
    expected_hz = {
        HEARTBEAT: 1.0,
        GLOBAL_POSITION_INT: 10.0,
        LOCAL_POSITION_NED: 10.0,
        ATTITUDE: 4.0,
        SYS_STATUS: 1.0,
        SYSTEM_TIME: 1.0,
        HOME_POSITION: 0.5,
    }
    assert set(sent) == set(expected_hz)
    for msg_id, hz in expected_hz.items():
        assert abs(len(sent[msg_id]) - 10.0 * hz) <= 1, msg_id
        # evenly spaced: no bursts, no gaps
        np.testing.assert_allclose(np.diff(sent[msg_id]), 1.0 / hz, atol=1e-9)


def test_a_rate_that_does_not_divide_the_tick_keeps_its_phase() -> None:
    schedule = TelemetrySchedule({ATTITUDE: 3.0})
    sent = _run(schedule, [i / 100.0 for i in range(10_000)])[ATTITUDE]  # 100 s
    assert abs(len(sent) - 300) <= 1  # no drift from rounding each interval up to a tick
    assert np.all(np.diff(sent) <= 1.0 / 3.0 + 0.01 + 1e-9)


def test_missed_slots_are_skipped_not_burst() -> None:
    schedule = TelemetrySchedule({GLOBAL_POSITION_INT: 10.0})
    assert schedule.due(0.0) == [GLOBAL_POSITION_INT]
    assert schedule.due(5.05) == [GLOBAL_POSITION_INT]  # 50 slots missed: one message
    assert schedule.due(5.06) == []
    assert schedule.due(5.09) == []
    assert schedule.due(5.10) == [GLOBAL_POSITION_INT]  # back on the 0.1 s grid


def test_set_interval_minus_one_stops_and_zero_restores_the_default() -> None:
    schedule = TelemetrySchedule(TelemetryRatesHz().by_id())
    _run(schedule, TICKS[:200])
    assert schedule.set_interval(GLOBAL_POSITION_INT, -1) is True
    stopped = _run(schedule, [2.0 + t for t in TICKS])
    assert GLOBAL_POSITION_INT not in stopped
    assert abs(len(stopped[LOCAL_POSITION_NED]) - 100) <= 1  # the others go on
    assert schedule.set_interval(GLOBAL_POSITION_INT, 0) is True
    restored = _run(schedule, [12.0 + t for t in TICKS])
    assert abs(len(restored[GLOBAL_POSITION_INT]) - 100) <= 1
    np.testing.assert_allclose(np.diff(restored[GLOBAL_POSITION_INT]), 0.1, atol=1e-9)


def test_set_interval_in_microseconds() -> None:
    schedule = TelemetrySchedule(TelemetryRatesHz().by_id())
    assert schedule.set_interval(ATTITUDE, 200_000) is True  # 200 ms: 5 Hz
    assert schedule.set_interval(HEARTBEAT, 50_000) is True  # 50 ms: 20 Hz
    sent = _run(schedule, TICKS)
    assert abs(len(sent[ATTITUDE]) - 50) <= 1
    assert abs(len(sent[HEARTBEAT]) - 200) <= 1
    np.testing.assert_allclose(np.diff(sent[ATTITUDE]), 0.2, atol=1e-9)


def test_unknown_message_ids_are_refused() -> None:
    schedule = TelemetrySchedule(TelemetryRatesHz().by_id())
    assert schedule.set_interval(26, 100_000) is False  # SCALED_IMU: the sim has no IMU data
    assert schedule.request_once(26) is False
    assert 26 not in _run(schedule, TICKS[:300])


def test_gps_raw_int_is_off_until_asked_for() -> None:
    schedule = TelemetrySchedule(TelemetryRatesHz().by_id())
    assert 24 not in _run(schedule, TICKS[:300])
    assert schedule.set_interval(24, 100_000) is True
    assert abs(len(_run(schedule, [6.0 + t for t in TICKS])[24]) - 100) <= 1


def test_request_once_sends_a_stopped_message_exactly_once() -> None:
    schedule = TelemetrySchedule(TelemetryRatesHz(home_position=0.0).by_id())
    assert HOME_POSITION not in _run(schedule, TICKS[:100])
    assert schedule.request_once(HOME_POSITION) is True
    sent = _run(schedule, [1.0 + t for t in TICKS])
    assert sent[HOME_POSITION] == [1.0]


def test_a_request_and_a_due_stream_in_the_same_tick_send_once() -> None:
    schedule = TelemetrySchedule({SYSTEM_TIME: 1.0})
    schedule.request_once(SYSTEM_TIME)
    assert schedule.due(0.0) == [SYSTEM_TIME]


def test_request_once_adds_one_message_without_shifting_the_stream() -> None:
    schedule = TelemetrySchedule({SYSTEM_TIME: 1.0})
    sent: list[float] = []
    for t in TICKS:
        if t == 0.5:
            schedule.request_once(SYSTEM_TIME)
        if SYSTEM_TIME in schedule.due(t):
            sent.append(t)
    assert sent == [0.0, 0.5, *(float(k) for k in range(1, 10))]


# --- FleetSnapshot ---------------------------------------------------------------------------

ORIGIN = frames.GeodeticOrigin(47.3769, 8.5417, 408.0)
NOW_S, UNIX_S = 12.5, 1_767_268_812.5

HOMES_ENU_M = np.array([[0.0, 0.0, 0.0], [250.0, -150.0, 0.0]])
P_ENU = np.array([[12.0, -7.0, 35.0], [300.0, -200.0, 50.0]])
V_ENU = np.array([[1.0, 2.0, 0.5], [-3.0, 4.0, -1.0]])
EULER_RAD = np.array([[0.1, 0.2, 0.0], [-0.05, 0.15, 2.5]])  # phi, theta, psi
RATES_FLU = np.array([[0.01, 0.02, 0.03], [0.3, -0.2, 0.1]])


def _state() -> FloatArray:
    state = np.zeros((2, STATE_SIZE))
    state[:, POS_ENU] = P_ENU
    state[:, VEL_ENU] = V_ENU
    state[:, EULER] = EULER_RAD
    state[:, BODY_RATES] = RATES_FLU
    return state


def _snapshot(state: FloatArray | None = None) -> tuple[FleetSnapshot, list[HomeFrame]]:
    homes = [HomeFrame(ORIGIN, home) for home in HOMES_ENU_M]
    snapshot = FleetSnapshot(NOW_S, UNIX_S, _state() if state is None else state, homes, ORIGIN)
    return snapshot, homes


def _ned_about_home(home: HomeFrame, p_enu: FloatArray) -> FloatArray:
    lat, lon, alt = frames.enu_to_geodetic(ORIGIN, p_enu)
    return frames.geodetic_to_ned(home.home_geodetic, lat, lon, alt)


@pytest.mark.parametrize("i", [0, 1])
def test_global_position_int_is_the_geodetic_position(i: int) -> None:
    snapshot, _ = _snapshot()
    gpi = snapshot.global_position_int(i)
    lat, lon, alt = frames.enu_to_geodetic(ORIGIN, P_ENU[i])
    _, _, home_alt = frames.enu_to_geodetic(ORIGIN, HOMES_ENU_M[i])
    assert gpi.time_boot_s == NOW_S
    assert gpi.lat_deg == pytest.approx(float(lat), abs=1e-12)
    assert gpi.lon_deg == pytest.approx(float(lon), abs=1e-12)
    assert gpi.alt_msl_m == pytest.approx(float(alt), abs=1e-6)
    assert gpi.relative_alt_m == pytest.approx(float(alt - home_alt), abs=1e-6)
    # ~ the height above the home in the flat-earth picture (curvature: millimetres)
    assert gpi.relative_alt_m == pytest.approx(P_ENU[i, 2], abs=0.02)


@pytest.mark.parametrize("i", [0, 1])
def test_global_position_int_velocity_is_ned(i: int) -> None:
    snapshot, homes = _snapshot()
    vx, vy, vz = V_ENU[i]
    v_ned = snapshot.global_position_int(i).v_ned_m_s
    # (vn, ve, vd) = (vy, vx, -vz); the home's north differs from the origin's by ~5e-5 rad
    np.testing.assert_allclose(v_ned, (vy, vx, -vz), atol=1e-3)
    exact = _ned_about_home(homes[i], P_ENU[i] + V_ENU[i]) - _ned_about_home(homes[i], P_ENU[i])
    np.testing.assert_allclose(v_ned, exact, atol=1e-6)


@pytest.mark.parametrize(
    ("psi", "heading_deg"),
    [
        (0.0, 90.0),  # facing east
        (math.pi / 2, 0.0),  # north
        (math.pi, 270.0),  # west
        (-math.pi / 2, 180.0),  # south
        (-math.pi / 4, 135.0),  # south-east
        (2.5, math.degrees(math.atan2(math.cos(2.5), math.sin(2.5))) % 360.0),
    ],
)
def test_heading_follows_yaw_clockwise_from_north(psi: float, heading_deg: float) -> None:
    state = _state()
    state[0, EULER] = (0.0, 0.0, psi)
    gpi = _snapshot(state)[0].global_position_int(0)
    assert gpi.heading_deg is not None
    assert 0.0 <= gpi.heading_deg < 360.0
    diff = (gpi.heading_deg - heading_deg + 180.0) % 360.0 - 180.0
    assert abs(diff) <= 1e-9


@pytest.mark.parametrize("i", [0, 1])
def test_local_position_ned_is_relative_to_the_vehicles_home(i: int) -> None:
    snapshot, homes = _snapshot()
    lpn = snapshot.local_position_ned(i)
    assert lpn.time_boot_s == NOW_S
    np.testing.assert_allclose(lpn.p_ned_m, _ned_about_home(homes[i], P_ENU[i]), atol=1e-6)
    e, n, u = P_ENU[i] - HOMES_ENU_M[i]
    np.testing.assert_allclose(lpn.p_ned_m, (n, e, -u), atol=0.02)  # flat-earth picture
    exact = _ned_about_home(homes[i], P_ENU[i] + V_ENU[i]) - _ned_about_home(homes[i], P_ENU[i])
    np.testing.assert_allclose(lpn.v_ned_m_s, exact, atol=1e-6)


def test_local_position_of_vehicle_at_its_home_is_zero() -> None:
    state = _state()
    state[1, POS_ENU] = HOMES_ENU_M[1]
    lpn = _snapshot(state)[0].local_position_ned(1)
    np.testing.assert_allclose(lpn.p_ned_m, (0.0, 0.0, 0.0), atol=1e-6)


T_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
D_FLU_FRD = np.diag([1.0, -1.0, -1.0])


@pytest.mark.parametrize("i", [0, 1])
def test_attitude_matches_the_rotation_matrices(i: int) -> None:
    att = _snapshot()[0].attitude(i)
    phi, theta, psi = EULER_RAD[i]
    r_enu_flu = Rotation.from_euler("ZYX", [psi, theta, phi]).as_matrix()
    r_ned_frd = T_ENU_NED @ r_enu_flu @ D_FLU_FRD
    yaw, pitch, roll = Rotation.from_matrix(r_ned_frd).as_euler("ZYX")
    assert att.time_boot_s == NOW_S
    assert att.roll_rad == pytest.approx(roll, abs=1e-9)
    assert att.pitch_rad == pytest.approx(pitch, abs=1e-9)
    assert (att.yaw_rad - yaw + math.pi) % math.tau - math.pi == pytest.approx(0.0, abs=1e-9)
    # the same, as the conventions read: roll = phi, pitch = -theta, yaw = pi/2 - psi
    assert (att.roll_rad, att.pitch_rad) == pytest.approx((phi, -theta), abs=1e-12)
    assert -math.pi <= att.yaw_rad < math.pi
    # body rates: omega_frd = D omega_flu
    np.testing.assert_allclose(att.rates_frd_rad_s, D_FLU_FRD @ RATES_FLU[i], atol=1e-12)


def test_home_system_time_and_status() -> None:
    snapshot, _ = _snapshot()
    home = snapshot.home_position(1)
    lat, lon, alt = frames.enu_to_geodetic(ORIGIN, HOMES_ENU_M[1])
    assert (home.lat_deg, home.lon_deg) == pytest.approx((float(lat), float(lon)), abs=1e-12)
    assert home.alt_msl_m == pytest.approx(float(alt), abs=1e-6)
    assert home.p_ned_m == (0.0, 0.0, 0.0)
    assert snapshot.system_time(0) == m.SystemTime(UNIX_S, NOW_S)
    status = snapshot.sys_status(0)
    prearm, geofence = 0x10000000, 0x100000
    assert status.sensors_present == status.sensors_enabled
    assert status.sensors_present & status.sensors_health == status.sensors_present
    assert status.sensors_health & geofence and not status.sensors_present & geofence
    waiting = snapshot.sys_status(0, prearm_ok=False)
    assert waiting.sensors_present & prearm and not waiting.sensors_health & prearm
