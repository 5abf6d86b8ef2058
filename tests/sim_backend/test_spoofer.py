"""The spoofer: a straight line at constant speed, and RID claims of truth + a constant offset.

Oracles: the claimed position is converted back with ``frames.geodetic_to_enu`` about the same
origin and compared with truth + offset (exact recovery: the domain message is unquantised, so
millimetres; over the air, the F3411 quantisation); the claimed course and speeds are derived by
hand from the ENU velocity; the cadence is counted over 10 s of 0.01 s calls.
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.common import frames, rid
from ridsafe.common import messages as m
from ridsafe.common.heard import decode_rid_frame
from ridsafe.sim_backend.spoofer import SpooferBroadcaster, StraightLineMission
from ridsafe.sim_backend.transponder import Transponder

FloatArray = NDArray[np.float64]

ORIGIN = frames.GeodeticOrigin(47.3769, 8.5417, 408.0)
START_UNIX_S = 1_767_268_800.0  # 2026-01-01T12:00:00Z, a full hour
GROUND_ENU_M = np.array([10.0, 20.0, 5.0])  # raised ground, so height != altitude above origin
OFFSET_ENU_M = np.array([50.0, -30.0, 10.0])  # asymmetric, with a vertical part
SERIAL = "RSAF800000009"

# --- StraightLineMission ---------------------------------------------------------------------

START = np.array([10.0, -20.0, 40.0])
GOAL = np.array([310.0, 380.0, 90.0])  # 300 E, 400 N, 50 up: 502.49 m
SPEED = 6.5
T0 = 2.0


def _mission() -> StraightLineMission:
    return StraightLineMission(START, GOAL, SPEED, t0_s=T0)


def test_the_target_moves_at_exactly_the_configured_speed_along_the_segment() -> None:
    mission = _mission()
    length = math.sqrt(300.0**2 + 400.0**2 + 50.0**2)
    unit = np.array([300.0, 400.0, 50.0]) / length
    arrival_s = T0 + length / SPEED
    times = np.linspace(T0, arrival_s - 0.01, 37)
    positions = []
    for t in times:
        p, v = mission.target(float(t))
        # on the segment, at distance speed * (t - t0) from the start
        assert np.linalg.norm(np.cross(p - START, unit)) == pytest.approx(0.0, abs=1e-9)
        assert float(np.dot(p - START, unit)) == pytest.approx(SPEED * (t - T0), abs=1e-9)
        # velocity = speed * unit direction
        np.testing.assert_allclose(v, SPEED * unit, atol=1e-12)
        positions.append(p)
    steps = np.linalg.norm(np.diff(np.array(positions), axis=0), axis=1)
    np.testing.assert_allclose(steps / np.diff(times), SPEED, rtol=1e-9)


def test_the_target_holds_the_goal_with_zero_velocity_after_arrival() -> None:
    mission = _mission()
    arrival_s = T0 + math.sqrt(300.0**2 + 400.0**2 + 50.0**2) / SPEED
    p_before, _ = mission.target(arrival_s - 0.1)
    assert np.linalg.norm(GOAL - p_before) == pytest.approx(0.1 * SPEED, abs=1e-9)
    for t in (arrival_s + 1e-6, arrival_s + 0.5, 1e6):
        p, v = mission.target(t)
        np.testing.assert_array_equal(p, GOAL)
        np.testing.assert_array_equal(v, np.zeros(3))
    p, _ = mission.target(1e6)
    p[:] = 0.0  # the caller's copy; the mission keeps its goal
    np.testing.assert_array_equal(mission.target(1e6)[0], GOAL)


def test_the_target_waits_at_the_start_until_t0() -> None:
    for t in (0.0, 1.0, T0):
        p, _ = _mission().target(t)
        np.testing.assert_array_equal(p, START)


def test_a_zero_length_mission_holds_its_point() -> None:
    mission = StraightLineMission(START, START, SPEED)
    p, v = mission.target(5.0)
    np.testing.assert_array_equal(p, START)
    np.testing.assert_array_equal(v, np.zeros(3))


# --- SpooferBroadcaster ----------------------------------------------------------------------


def _broadcaster(phase_s: float = 0.0) -> SpooferBroadcaster:
    return SpooferBroadcaster(SERIAL, OFFSET_ENU_M, ORIGIN, START_UNIX_S, GROUND_ENU_M, phase_s)


P_ENU_M = np.array([123.4, -56.7, 42.0])
V_ENU_M_S = np.array([3.0, -4.0, 1.5])  # 3 east, 4 south, climbing: course 143.13 deg, 5 m/s


@pytest.mark.parametrize("phase_s", [0.0, 0.37])
def test_location_every_second_and_the_static_messages_every_three(phase_s: float) -> None:
    spoofer = _broadcaster(phase_s)
    sent: dict[type, list[float]] = defaultdict(list)
    for i in range(1000):  # 10 s of 0.01 s calls
        t = i / 100.0
        for msg in spoofer.due(t, P_ENU_M, V_ENU_M_S):
            sent[type(msg)].append(t)
    assert set(sent) == {m.OdidLocation, m.OdidBasicId, m.OdidSystem, m.OdidOperatorId}
    np.testing.assert_allclose(sent[m.OdidLocation], phase_s + np.arange(10.0), atol=0.005)
    for kind in (m.OdidBasicId, m.OdidSystem, m.OdidOperatorId):
        np.testing.assert_allclose(sent[kind], phase_s + 3.0 * np.arange(4.0), atol=0.005)


def _location_at(
    spoofer: SpooferBroadcaster, now_s: float, p: FloatArray, v: FloatArray
) -> m.OdidLocation:
    locations = [x for x in spoofer.due(now_s, p, v) if isinstance(x, m.OdidLocation)]
    assert len(locations) == 1
    return locations[0]


def test_the_claimed_position_is_truth_plus_the_offset() -> None:
    spoofer = _broadcaster()
    loc = _location_at(spoofer, 0.0, P_ENU_M, V_ENU_M_S)
    assert loc.lat_deg is not None and loc.lon_deg is not None
    assert loc.alt_geodetic_m is not None
    claimed = frames.geodetic_to_enu(ORIGIN, loc.lat_deg, loc.lon_deg, loc.alt_geodetic_m)
    np.testing.assert_allclose(claimed, P_ENU_M + OFFSET_ENU_M, atol=1e-3)
    # height above the take-off point (the ground), not above the scenario origin
    assert loc.height_m == pytest.approx(42.0 + 10.0 - 5.0, abs=1e-9)
    np.testing.assert_allclose(spoofer.claimed_p_enu_m(P_ENU_M), P_ENU_M + OFFSET_ENU_M)


def test_each_location_uses_the_position_at_its_own_time() -> None:
    spoofer = _broadcaster(phase_s=0.25)
    p0 = np.array([0.0, 200.0, 40.0])
    v = np.array([7.0, 0.0, 0.0])
    claims = []
    for i in range(400):
        t = i / 100.0
        for msg in spoofer.due(t, p0 + v * t, v):
            if isinstance(msg, m.OdidLocation):
                assert msg.lat_deg is not None and msg.lon_deg is not None
                assert msg.alt_geodetic_m is not None
                enu = frames.geodetic_to_enu(ORIGIN, msg.lat_deg, msg.lon_deg, msg.alt_geodetic_m)
                claims.append((t, enu))
    assert [t for t, _ in claims] == pytest.approx([0.25, 1.25, 2.25, 3.25])
    for t, enu in claims:
        np.testing.assert_allclose(enu, p0 + v * t + OFFSET_ENU_M, atol=1e-3)


def test_the_claimed_velocity_is_the_true_velocity() -> None:
    loc = _location_at(_broadcaster(), 0.0, P_ENU_M, V_ENU_M_S)
    assert loc.speed_horizontal_m_s == pytest.approx(5.0, abs=1e-12)
    # course clockwise from north of (east 3, north -4)
    assert loc.course_deg == pytest.approx(180.0 - math.degrees(math.atan(3.0 / 4.0)), abs=1e-9)
    assert loc.speed_vertical_m_s == pytest.approx(1.5, abs=1e-12)  # up positive


def test_the_claim_survives_the_air_within_f3411_quantisation() -> None:
    spoofer = _broadcaster()
    sender, receiver = Transponder(5, SERIAL.encode()), Transponder(1, b"RSAF800000001")
    loc = _location_at(spoofer, 0.0, P_ENU_M, V_ENU_M_S)
    frame = sender.on_message(0.0, loc)
    assert frame is not None
    report = receiver.report(frame, SERIAL.encode(), -60.0)
    (heard,) = decode_rid_frame(report.frame, report.sender_id).messages
    assert isinstance(heard, m.OdidLocation)
    assert heard.lat_deg is not None and heard.lon_deg is not None
    assert heard.alt_geodetic_m is not None
    claimed = frames.geodetic_to_enu(ORIGIN, heard.lat_deg, heard.lon_deg, heard.alt_geodetic_m)
    truth = P_ENU_M + OFFSET_ENU_M
    # 0.5e-7 deg is 0.56 cm of latitude and 0.38 cm of longitude here; altitude in 0.5 m steps
    assert np.hypot(*(claimed[:2] - truth[:2])) <= 0.02
    assert abs(claimed[2] - truth[2]) <= 0.5
    assert heard.course_deg == 143.0  # whole degrees on the air
    assert heard.speed_horizontal_m_s == 5.0
    assert heard.speed_vertical_m_s == 1.5


def test_the_spoofer_does_not_declare_an_emergency() -> None:
    spoofer = _broadcaster()
    airborne = _location_at(spoofer, 0.0, P_ENU_M, V_ENU_M_S)
    assert airborne.status == int(m.OdidStatus.AIRBORNE)
    on_ground = _location_at(spoofer, 1.0, GROUND_ENU_M.copy(), np.zeros(3))
    assert on_ground.status == int(m.OdidStatus.GROUND)
    assert int(m.OdidStatus.EMERGENCY) not in (airborne.status, on_ground.status)


def test_the_static_messages_identify_the_spoofer_and_its_operator_on_the_ground() -> None:
    spoofer = _broadcaster()
    messages = spoofer.due(3.0, P_ENU_M, V_ENU_M_S)  # phase 0: the first call at 3 s
    (basic,) = [x for x in messages if isinstance(x, m.OdidBasicId)]
    (system,) = [x for x in messages if isinstance(x, m.OdidSystem)]
    assert [x for x in messages if isinstance(x, m.OdidOperatorId)]
    assert basic.uas_id_str == SERIAL
    assert basic.id_type == m.OdidIdType.SERIAL_NUMBER
    assert system.operator_lat_deg is not None and system.operator_lon_deg is not None
    assert system.operator_alt_geo_m is not None
    operator = frames.geodetic_to_enu(
        ORIGIN, system.operator_lat_deg, system.operator_lon_deg, system.operator_alt_geo_m
    )
    np.testing.assert_allclose(operator, GROUND_ENU_M, atol=1e-3)  # the truth, no offset
    assert system.timestamp_s == int(START_UNIX_S + 3.0) - rid.ODID_EPOCH_UNIX_S


def test_location_timestamps_are_seconds_after_the_hour_of_sim_time() -> None:
    spoofer = _broadcaster(phase_s=0.63)
    stamps = []
    for i in range(300):
        for msg in spoofer.due(i / 100.0, P_ENU_M, V_ENU_M_S):
            if isinstance(msg, m.OdidLocation):
                stamps.append(msg.timestamp_s)
    # START_UNIX_S is a full hour: sent at 0.63, 1.63, 2.63 s -> 0.6, 1.6, 2.6 s after it
    assert stamps == pytest.approx([0.6, 1.6, 2.6], abs=1e-9)


def test_a_gap_in_calls_does_not_make_the_spoofer_burst() -> None:
    spoofer = _broadcaster()
    spoofer.due(0.0, P_ENU_M, V_ENU_M_S)
    assert any(isinstance(x, m.OdidLocation) for x in spoofer.due(5.0, P_ENU_M, V_ENU_M_S))
    burst = [
        t
        for t in (5.01, 5.02, 5.03, 5.04)
        if any(isinstance(x, m.OdidLocation) for x in spoofer.due(t, P_ENU_M, V_ENU_M_S))
    ]
    assert burst == []
