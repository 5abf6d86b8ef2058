"""Building an aircraft's own Remote ID messages (ridsafe.common.rid) from its state.

Oracles: course and speeds derived by hand from asymmetric NED velocities (course clockwise from
north: east 90, south 180, west 270), UTC times from ``datetime`` (not from ``math.fmod``), and
the F3411 / MAVLink conventions (vertical speed up positive, SYSTEM timestamps from 2019-01-01).
"""

from __future__ import annotations

import math
from datetime import UTC, datetime

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import messages as m
from ridsafe.common import rid


def _unix(
    year: int, month: int, day: int, hour: int, minute: int, second: int, microsecond: int = 0
) -> float:
    return datetime(year, month, day, hour, minute, second, microsecond, tzinfo=UTC).timestamp()


def _state(
    v_ned_m_s: m.Vec3 = (0.0, 0.0, 0.0),
    airborne: bool = True,
    emergency: bool = False,
    unix_s: float = 1_767_268_800.0,
) -> rid.OwnState:
    return rid.OwnState(
        unix_s=unix_s,
        lat_deg=-33.8567844,
        lon_deg=151.2152967,
        alt_geodetic_m=85.25,
        height_m=60.5,
        v_ned_m_s=v_ned_m_s,
        airborne=airborne,
        emergency=emergency,
    )


@pytest.mark.parametrize(
    ("v_ned", "course_deg", "speed_m_s"),
    [
        ((5.0, 0.0, 0.0), 0.0, 5.0),  # north
        ((0.0, 3.0, 0.0), 90.0, 3.0),  # east
        ((-2.0, 0.0, 0.0), 180.0, 2.0),  # south
        ((0.0, -4.0, 0.0), 270.0, 4.0),  # west
        ((-3.0, -3.0, 0.0), 225.0, math.sqrt(18.0)),  # south-west
        ((4.0, -3.0, 0.0), 360.0 - math.degrees(math.atan(3.0 / 4.0)), 5.0),  # north-north-west
        ((1.0, math.sqrt(3.0), 0.0), 60.0, 2.0),  # 60 deg clockwise from north
    ],
)
def test_location_course_is_clockwise_from_north(
    v_ned: m.Vec3, course_deg: float, speed_m_s: float
) -> None:
    loc = rid.location(_state(v_ned))
    assert loc.course_deg == pytest.approx(course_deg, abs=1e-9)
    assert loc.speed_horizontal_m_s == pytest.approx(speed_m_s, abs=1e-12)


def test_location_vertical_speed_is_up_positive() -> None:
    assert rid.location(_state((1.0, 2.0, -2.5))).speed_vertical_m_s == 2.5  # climbing
    assert rid.location(_state((1.0, 2.0, 1.5))).speed_vertical_m_s == -1.5  # descending


def test_location_course_is_unknown_when_hovering() -> None:
    assert rid.location(_state((0.005, -0.005, 0.3))).course_deg is None
    assert rid.location(_state((0.0, 0.011, 0.0))).course_deg == pytest.approx(90.0)


def test_location_copies_position_and_reports_gnss_accuracies() -> None:
    loc = rid.location(_state((1.0, 1.0, 0.0)), id_or_mac=b"\x01\x02")
    assert loc.id_or_mac == b"\x01\x02"
    assert (loc.lat_deg, loc.lon_deg) == (-33.8567844, 151.2152967)
    assert (loc.alt_geodetic_m, loc.height_m, loc.height_reference) == (85.25, 60.5, 0)
    assert loc.alt_baro_m is None  # no barometer in the broadcast
    # MAV_ODID_HOR_ACC_3_METER 11, VER_ACC_3_METER 5, SPEED_ACC_0_3 4, TIME_ACC_0_1 1
    assert (loc.horizontal_accuracy, loc.vertical_accuracy) == (11, 5)
    assert (loc.speed_accuracy, loc.timestamp_accuracy, loc.barometer_accuracy) == (4, 1, 0)


@pytest.mark.parametrize(
    ("airborne", "emergency", "status"),
    [
        (False, False, m.OdidStatus.GROUND),
        (True, False, m.OdidStatus.AIRBORNE),
        (True, True, m.OdidStatus.EMERGENCY),
        (False, True, m.OdidStatus.EMERGENCY),
    ],
)
def test_location_status(airborne: bool, emergency: bool, status: m.OdidStatus) -> None:
    loc = rid.location(_state(airborne=airborne, emergency=emergency))
    assert loc.status == int(status)


@pytest.mark.parametrize(
    ("utc", "seconds"),
    [
        ((2026, 1, 1, 12, 0, 0), 0.0),
        ((2026, 1, 1, 12, 34, 56), 34 * 60 + 56.0),
        ((2026, 3, 9, 7, 59, 59), 3599.0),
        ((2031, 12, 31, 23, 0, 1), 1.0),
    ],
)
def test_seconds_after_the_full_hour(
    utc: tuple[int, int, int, int, int, int], seconds: float
) -> None:
    assert rid.seconds_after_hour(_unix(*utc)) == pytest.approx(seconds, abs=1e-6)


def test_location_timestamp_is_seconds_after_the_hour_in_tenths() -> None:
    unix_s = _unix(2026, 1, 1, 12, 34, 56, microsecond=730_000)
    assert rid.location(_state(unix_s=unix_s)).timestamp_s == pytest.approx(2096.7, abs=1e-9)
    unix_s = _unix(2026, 1, 1, 12, 34, 56, microsecond=740_000)
    assert rid.location(_state(unix_s=unix_s)).timestamp_s == pytest.approx(2096.7, abs=1e-9)
    unix_s = _unix(2026, 1, 1, 12, 34, 56, microsecond=760_000)
    assert rid.location(_state(unix_s=unix_s)).timestamp_s == pytest.approx(2096.8, abs=1e-9)


@settings(max_examples=150)
@given(
    vn=st.floats(-30.0, 30.0),
    ve=st.floats(-30.0, 30.0),
    vd=st.floats(-10.0, 10.0),
    unix_s=st.floats(1.6e9, 2.0e9),
)
def test_location_matches_its_definitions_for_any_state(
    vn: float, ve: float, vd: float, unix_s: float
) -> None:
    loc = rid.location(_state((vn, ve, vd), unix_s=unix_s))
    speed = math.hypot(vn, ve)
    assert loc.speed_horizontal_m_s == pytest.approx(speed, abs=1e-12)
    assert loc.speed_vertical_m_s == -vd
    if speed < 0.01:
        assert loc.course_deg is None
    else:
        assert loc.course_deg is not None
        # the course points along the velocity: (sin c, cos c) = (ve, vn) / speed
        c = math.radians(loc.course_deg)
        assert math.sin(c) * speed == pytest.approx(ve, abs=1e-9)
        assert math.cos(c) * speed == pytest.approx(vn, abs=1e-9)
    assert loc.timestamp_s is not None
    assert 0.0 <= loc.timestamp_s <= 3600.0
    after_hour = unix_s - 3600.0 * math.floor(unix_s / 3600.0)
    assert abs(loc.timestamp_s - after_hour) <= 0.05 + 1e-6


def test_location_course_is_below_360() -> None:
    course = rid.location(_state((1.0, -1e-17, 0.0))).course_deg
    assert course is not None
    assert 0.0 <= course < 360.0


def test_basic_id_is_a_serial_number_of_a_multirotor() -> None:
    basic = rid.basic_id("RSAF800000001")
    assert basic == m.OdidBasicId(b"", 1, 2, b"RSAF800000001")
    assert basic.uas_id_str == "RSAF800000001"
    assert basic.id_type == m.OdidIdType.SERIAL_NUMBER
    assert basic.ua_type == m.OdidUaType.HELICOPTER_OR_MULTIROTOR


def test_id_bytes_accepts_20_characters_and_rejects_21() -> None:
    assert rid.id_bytes("A" * 20) == b"A" * 20
    with pytest.raises(ValueError, match="longer than 20"):
        rid.id_bytes("A" * 21)
    with pytest.raises(UnicodeEncodeError):
        rid.id_bytes("SERIAL\u00e9")


def test_system_timestamp_counts_seconds_since_2019() -> None:
    assert _unix(2019, 1, 1, 0, 0, 0) == rid.ODID_EPOCH_UNIX_S
    unix_s = _unix(2026, 1, 1, 12, 0, 0) + 0.9
    since_2019 = datetime(2026, 1, 1, 12, tzinfo=UTC) - datetime(2019, 1, 1, tzinfo=UTC)
    expected = int(since_2019.total_seconds())
    assert rid.odid_system_timestamp(unix_s) == expected  # truncated, not rounded
    assert rid.odid_system_timestamp(_unix(2018, 6, 1, 0, 0, 0)) == 0  # before the epoch


def test_system_reports_the_operator_at_the_take_off_location() -> None:
    unix_s = _unix(2026, 1, 1, 12, 0, 0)
    system = rid.system(unix_s, 47.5, -8.25, 433.0)
    assert system.operator_location_type == 0  # MAV_ODID_OPERATOR_LOCATION_TYPE_TAKEOFF
    assert (system.operator_lat_deg, system.operator_lon_deg) == (47.5, -8.25)
    assert system.operator_alt_geo_m == 433.0
    assert system.area_count == 1
    assert (system.area_ceiling_m, system.area_floor_m) == (None, None)
    assert system.timestamp_s == rid.odid_system_timestamp(unix_s) > 0
    update = rid.system_update(unix_s + 10.0, 47.6, -8.3, 440.0)
    assert update == m.OdidSystemUpdate(47.6, -8.3, 440.0, system.timestamp_s + 10)


def test_operator_id() -> None:
    assert rid.operator_id("FIN87astrdge12k8") == m.OdidOperatorId(b"", 0, "FIN87astrdge12k8")


def test_broadcast_periods_are_what_arducopter_expects() -> None:
    assert rid.RID_LOCATION_PERIOD_S <= 1.0  # LOCATION at >= 1 Hz
    assert rid.RID_STATIC_PERIOD_S <= 3.0  # every other message at least every 3 s
