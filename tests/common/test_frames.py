"""Tests for ridsafe.common.frames against independent oracles.

Oracles: an iterative ECEF -> geodetic solver written here, the meridian/prime-vertical radii of
curvature for small offsets, and scipy's Rotation for the attitude conventions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ridsafe.common.frames import (
    COURSE_MIN_SPEED_MPS,
    WGS84_A_M,
    WGS84_E2,
    GeodeticOrigin,
    attitude_mavlink_to_sim,
    attitude_sim_to_mavlink,
    body_rates_flu_to_frd,
    body_rates_frd_to_flu,
    course_deg_from_velocity_enu,
    course_deg_from_velocity_ned,
    cov_enu_to_ned,
    cov_ned_to_enu,
    ecef_to_geodetic,
    enu_to_geodetic,
    enu_to_geodetic_point,
    enu_to_ned,
    geodetic_to_ecef,
    geodetic_to_enu,
    geodetic_to_enu_point,
    geodetic_to_ned,
    ned_to_enu,
    ned_to_geodetic,
    wrap_pi,
)

ORIGINS = [
    GeodeticOrigin(47.3977, 8.5456, 488.0),  # Zurich (PX4 SITL home)
    GeodeticOrigin(0.0, 0.0, 0.0),
    GeodeticOrigin(-35.3632, 149.1652, 584.0),  # Canberra (ArduPilot SITL home)
    GeodeticOrigin(89.99, 45.0, 100.0),  # 1.1 km from the North Pole: +/-5 km crosses it
    GeodeticOrigin(-90.0, 0.0, 2800.0),  # the South Pole itself
    GeodeticOrigin(12.0, 179.99, 10.0),  # 1 km west of the antimeridian
    GeodeticOrigin(-20.0, -180.0, 0.0),  # on the antimeridian
]

T_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
D_FLU_FRD = np.diag([1.0, -1.0, -1.0])

local_offsets = st.tuples(
    st.floats(-5000.0, 5000.0), st.floats(-5000.0, 5000.0), st.floats(-500.0, 500.0)
)
angles = st.floats(-math.pi, math.pi, allow_nan=False)


def iterative_geodetic(p_ecef: NDArray[np.float64]) -> tuple[float, float, float]:
    """Independent oracle: fixed-point iteration on latitude (fine away from the poles)."""
    x, y, z = (float(c) for c in p_ecef)
    lon = math.atan2(y, x)
    r_xy = math.hypot(x, y)
    lat = math.atan2(z, r_xy * (1.0 - WGS84_E2))
    h = 0.0
    for _ in range(20):
        n = WGS84_A_M / math.sqrt(1.0 - WGS84_E2 * math.sin(lat) ** 2)
        h = r_xy / math.cos(lat) - n
        lat = math.atan2(z, r_xy * (1.0 - WGS84_E2 * n / (n + h)))
    return math.degrees(lat), math.degrees(lon), h


def lon_diff_deg(a: object, b: object) -> float:
    """Largest absolute longitude difference in degrees, across the antimeridian."""
    diff = (np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64) + 180.0) % 360.0
    return float(np.max(np.abs(diff - 180.0)))


# --------------------------------------------------------------------------------------------
# GeodeticOrigin


@pytest.mark.parametrize(
    ("lat", "lon", "alt", "field"),
    [
        (90.0001, 0.0, 0.0, "lat_deg"),
        (-91.0, 0.0, 0.0, "lat_deg"),
        (0.0, 180.5, 0.0, "lon_deg"),
        (0.0, -181.0, 0.0, "lon_deg"),
        (math.nan, 0.0, 0.0, "lat_deg"),
        (0.0, math.inf, 0.0, "lon_deg"),
        (0.0, 0.0, math.nan, "alt_m"),
    ],
)
def test_origin_rejects_out_of_range(lat: float, lon: float, alt: float, field: str) -> None:
    with pytest.raises(ValueError, match=f"^{field}: expected"):
        GeodeticOrigin(lat, lon, alt)


def test_origin_accepts_the_limits() -> None:
    GeodeticOrigin(90.0, 180.0, -100.0)
    GeodeticOrigin(-90.0, -180.0, 9000.0)


# --------------------------------------------------------------------------------------------
# Geodetic <-> ECEF


def test_ecef_known_points() -> None:
    b = WGS84_A_M * (1.0 - 1.0 / 298.257223563)
    np.testing.assert_allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [WGS84_A_M, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(
        geodetic_to_ecef(0.0, 90.0, 10.0), [0.0, WGS84_A_M + 10, 0.0], atol=1e-9
    )
    np.testing.assert_allclose(geodetic_to_ecef(90.0, 0.0, 0.0), [0.0, 0.0, b], atol=1e-9)
    np.testing.assert_allclose(geodetic_to_ecef(-90.0, 33.0, 5.0), [0.0, 0.0, -b - 5.0], atol=1e-9)


@settings(max_examples=200)
@given(
    st.floats(-89.0, 89.0),
    st.floats(-180.0, 180.0),
    st.floats(-500.0, 20000.0),
)
def test_ecef_to_geodetic_matches_an_iterative_solver(lat: float, lon: float, alt: float) -> None:
    p = geodetic_to_ecef(lat, lon, alt)
    got = ecef_to_geodetic(p)
    want = iterative_geodetic(p)
    assert got[0] == pytest.approx(want[0], abs=1e-9)
    assert lon_diff_deg(got[1], want[1]) < 1e-9
    assert got[2] == pytest.approx(want[2], abs=1e-6)
    assert got[2] == pytest.approx(alt, abs=1e-6)


@pytest.mark.parametrize("lat", [90.0, -90.0, 89.9999999, 0.0])
def test_ecef_to_geodetic_at_poles_and_equator(lat: float) -> None:
    got_lat, _, got_alt = ecef_to_geodetic(geodetic_to_ecef(lat, 30.0, 123.0))
    assert got_lat == pytest.approx(lat, abs=1e-10)
    assert got_alt == pytest.approx(123.0, abs=1e-6)


# --------------------------------------------------------------------------------------------
# Geodetic <-> ENU / NED


@pytest.mark.parametrize("origin", ORIGINS, ids=str)
def test_origin_maps_to_zero(origin: GeodeticOrigin) -> None:
    p = geodetic_to_enu(origin, origin.lat_deg, origin.lon_deg, origin.alt_m)
    assert p.shape == (3,)
    np.testing.assert_allclose(p, 0.0, atol=1e-6)


def test_small_offsets_match_radii_of_curvature() -> None:
    origin = GeodeticOrigin(47.3977, 8.5456, 488.0)
    lat = math.radians(origin.lat_deg)
    w = 1.0 - WGS84_E2 * math.sin(lat) ** 2
    meridian_radius = WGS84_A_M * (1.0 - WGS84_E2) / w**1.5
    prime_vertical_radius = WGS84_A_M / math.sqrt(w)
    north = geodetic_to_enu(origin, origin.lat_deg + 1e-4, origin.lon_deg, origin.alt_m)
    east = geodetic_to_ned(origin, origin.lat_deg, origin.lon_deg + 1e-4, origin.alt_m)
    expected_north = (meridian_radius + origin.alt_m) * math.radians(1e-4)
    expected_east = (prime_vertical_radius + origin.alt_m) * math.cos(lat) * math.radians(1e-4)
    assert expected_north == pytest.approx(11.12, abs=0.01)  # "1e-4 deg is ~11.1 m"
    np.testing.assert_allclose(north, [0.0, expected_north, 0.0], atol=2e-4)
    np.testing.assert_allclose(east, [0.0, expected_east, 0.0], atol=2e-4)
    up = geodetic_to_ned(origin, origin.lat_deg, origin.lon_deg, origin.alt_m + 10.0)
    np.testing.assert_allclose(up, [0.0, 0.0, -10.0], atol=1e-9)


def test_local_frame_is_not_flat_earth() -> None:
    """5 km away at the origin's altitude lies ~2 m below the tangent plane."""
    origin = GeodeticOrigin(47.0, 8.0, 0.0)
    _, _, alt = enu_to_geodetic(origin, [5000.0, 0.0, 0.0])
    assert alt == pytest.approx(5000.0**2 / (2 * 6.38e6), rel=0.01)


def test_across_the_antimeridian() -> None:
    origin = GeodeticOrigin(0.0, 179.99, 0.0)
    p = geodetic_to_enu(origin, 0.0, -179.99, 0.0)  # 0.02 deg east, across the date line
    assert p[0] == pytest.approx(WGS84_A_M * math.radians(0.02), rel=1e-6)
    _, lon, _ = enu_to_geodetic(origin, [2000.0, 0.0, 0.0])
    assert -180.0 < lon < -179.97


@pytest.mark.parametrize("origin", ORIGINS, ids=str)
@settings(max_examples=60)
@given(offset=local_offsets)
def test_enu_round_trip_is_sub_millimetre(
    origin: GeodeticOrigin, offset: tuple[float, float, float]
) -> None:
    p = np.array(offset)
    lat, lon, alt = enu_to_geodetic(origin, p)
    back = geodetic_to_enu(origin, lat, lon, alt)
    assert np.max(np.abs(back - p)) < 1e-3
    lat2, lon2, alt2 = ned_to_geodetic(origin, geodetic_to_ned(origin, lat, lon, alt))
    assert abs(lat2 - lat) < 1e-10 and lon_diff_deg(lon2, lon) < 1e-8 and abs(alt2 - alt) < 1e-3


@pytest.mark.parametrize("origin", ORIGINS, ids=str)
def test_vectorised_round_trip_over_a_grid(origin: GeodeticOrigin) -> None:
    rng = np.random.default_rng(7)
    p = rng.uniform([-5000, -5000, -500], [5000, 5000, 500], size=(1000, 3))
    lat, lon, alt = enu_to_geodetic(origin, p)
    assert lat.shape == lon.shape == alt.shape == (1000,)
    back = geodetic_to_enu(origin, lat, lon, alt)
    assert back.shape == (1000, 3)
    assert np.max(np.abs(back - p)) < 1e-3
    assert np.all(np.abs(lat) <= 90.0) and np.all(np.abs(lon) <= 180.0)


def test_shapes_broadcast() -> None:
    origin = GeodeticOrigin(47.0, 8.0, 0.0)
    lat = np.full((2, 5), 47.001)
    assert geodetic_to_enu(origin, lat, 8.0, 0.0).shape == (2, 5, 3)
    assert geodetic_to_ned(origin, [47.0, 47.001], 8.0, [0.0, 5.0]).shape == (2, 3)
    lat_out, _, _ = ned_to_geodetic(origin, np.zeros((4, 2, 3)))
    assert lat_out.shape == (4, 2)


def test_enu_ned_vectors_are_asymmetric_swaps() -> None:
    v = np.array([[1.0, 2.0, 3.0], [-4.0, 5.0, -6.0]])
    np.testing.assert_array_equal(enu_to_ned(v), [[2.0, 1.0, -3.0], [5.0, -4.0, 6.0]])
    np.testing.assert_array_equal(ned_to_enu(enu_to_ned(v)), v)
    np.testing.assert_array_equal(enu_to_ned(v), v @ T_ENU_NED.T)
    assert enu_to_ned([1.0, 2.0, 3.0]).shape == (3,)


def test_covariance_conversion_is_t_p_t_transpose() -> None:
    """An asymmetric covariance (every entry distinct) against the matrix product, and a
    batch; the round trip is exact."""
    a = np.array([[3.0, 0.5, -0.2], [0.7, 2.0, 0.1], [-0.4, 0.3, 1.5]])
    cov_enu = a @ a.T
    expected = T_ENU_NED @ cov_enu @ T_ENU_NED.T
    np.testing.assert_allclose(cov_enu_to_ned(cov_enu), expected, rtol=0, atol=1e-15)
    # the vertical variance stays, the east-north block swaps, cross terms with up change sign
    ned = cov_enu_to_ned(cov_enu)
    assert ned[2, 2] == cov_enu[2, 2] and ned[0, 0] == cov_enu[1, 1]
    assert ned[0, 2] == -cov_enu[1, 2] and ned[1, 2] == -cov_enu[0, 2]
    batch = np.stack((cov_enu, 2.0 * cov_enu))
    np.testing.assert_array_equal(cov_enu_to_ned(batch)[1], cov_enu_to_ned(2.0 * cov_enu))
    np.testing.assert_array_equal(cov_ned_to_enu(cov_enu_to_ned(cov_enu)), cov_enu)


# --------------------------------------------------------------------------------------------
# Attitude


def r_zyx(yaw: float, pitch: float, roll: float) -> NDArray[np.float64]:
    """Rz(yaw) Ry(pitch) Rx(roll), by scipy (intrinsic 'ZYX')."""
    m: NDArray[np.float64] = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
    return m


def test_sim_convention_theta_positive_is_nose_down() -> None:
    forward_enu = r_zyx(0.0, 0.3, 0.0) @ [1.0, 0.0, 0.0]
    assert forward_enu[2] < 0.0  # up component negative
    assert (r_zyx(0.0, 0.0, 0.0) @ [1.0, 0.0, 0.0])[0] == 1.0  # psi = 0 faces east


def test_known_asymmetric_attitude() -> None:
    # sim: facing 30 deg left of east (i.e. 60 deg clockwise from north), nose 10 deg down,
    # rolled 5 deg -> MAVLink yaw 60 deg, pitch -10 deg, roll 5 deg.
    roll, pitch, yaw = attitude_sim_to_mavlink(
        math.radians(5.0), math.radians(10.0), math.radians(30.0)
    )
    assert math.degrees(roll) == pytest.approx(5.0)
    assert math.degrees(pitch) == pytest.approx(-10.0)
    assert math.degrees(yaw) == pytest.approx(60.0)
    forward_ned = r_zyx(yaw, pitch, roll) @ [1.0, 0.0, 0.0]
    assert forward_ned[2] > 0.0  # nose down: positive down component


@settings(max_examples=300)
@given(phi=angles, theta=st.floats(-math.pi / 2, math.pi / 2), psi=angles)
def test_attitude_conversion_agrees_with_rotation_matrices(
    phi: float, theta: float, psi: float
) -> None:
    r_ned_frd = T_ENU_NED @ r_zyx(psi, theta, phi) @ D_FLU_FRD
    roll, pitch, yaw = attitude_sim_to_mavlink(phi, theta, psi)
    np.testing.assert_allclose(r_zyx(yaw, pitch, roll), r_ned_frd, atol=1e-12)
    assert -math.pi <= yaw < math.pi
    assume(abs(abs(theta) - math.pi / 2) > 1e-3)  # Euler angles are unique away from gimbal lock
    want_yaw, want_pitch, want_roll = Rotation.from_matrix(r_ned_frd).as_euler("ZYX")
    assert abs(wrap_pi(yaw - want_yaw)) < 1e-9
    assert pitch == pytest.approx(want_pitch, abs=1e-9)
    assert abs(wrap_pi(roll - want_roll)) < 1e-9


@settings(max_examples=300)
@given(roll=angles, pitch=st.floats(-math.pi / 2, math.pi / 2), yaw=angles)
def test_inverse_attitude_conversion(roll: float, pitch: float, yaw: float) -> None:
    phi, theta, psi = attitude_mavlink_to_sim(roll, pitch, yaw)
    r_enu_flu = T_ENU_NED @ r_zyx(yaw, pitch, roll) @ D_FLU_FRD
    np.testing.assert_allclose(r_zyx(psi, theta, phi), r_enu_flu, atol=1e-12)
    back = attitude_sim_to_mavlink(phi, theta, psi)
    assert back[0] == roll and back[1] == pitch
    assert abs(wrap_pi(back[2] - yaw)) < 1e-12


@settings(max_examples=200)
@given(
    phi=angles,
    theta=st.floats(-1.5, 1.5),
    psi=angles,
    rates=st.tuples(*[st.floats(-10.0, 10.0)] * 3),
)
def test_body_rates_describe_the_same_world_angular_velocity(
    phi: float, theta: float, psi: float, rates: tuple[float, float, float]
) -> None:
    r_enu_flu = r_zyx(psi, theta, phi)
    roll, pitch, yaw = attitude_sim_to_mavlink(phi, theta, psi)
    rates_frd = body_rates_flu_to_frd(*rates)
    omega_ned_from_sim = T_ENU_NED @ (r_enu_flu @ np.array(rates))
    omega_ned_from_mav = r_zyx(yaw, pitch, roll) @ np.array(rates_frd)
    np.testing.assert_allclose(omega_ned_from_mav, omega_ned_from_sim, atol=1e-9)
    assert body_rates_frd_to_flu(*rates_frd) == rates


def test_attitude_functions_are_elementwise_on_arrays() -> None:
    phi = np.array([0.1, -0.2])
    theta = np.array([0.3, 0.0])
    psi = np.array([0.0, math.pi])
    roll, pitch, yaw = attitude_sim_to_mavlink(phi, theta, psi)
    np.testing.assert_allclose(roll, phi)
    np.testing.assert_allclose(pitch, -theta)
    np.testing.assert_allclose(yaw, [math.pi / 2, -math.pi / 2])


def test_wrap_pi_range() -> None:
    values = np.array([-3 * math.pi, -math.pi, 0.0, math.pi, 2.5 * math.pi])
    wrapped = wrap_pi(values)
    np.testing.assert_allclose(wrapped, [-math.pi, -math.pi, 0.0, -math.pi, 0.5 * math.pi])
    assert np.all((wrapped >= -math.pi) & (wrapped < math.pi))


# --------------------------------------------------------------------------------------------
# Course


@pytest.mark.parametrize(
    ("v_ned", "course"),
    [
        ((1.0, 0.0, 0.0), 0.0),
        ((0.0, 2.0, 0.0), 90.0),
        ((-3.0, 0.0, 1.0), 180.0),
        ((0.0, -1.0, -1.0), 270.0),
        ((1.0, math.sqrt(3.0), 0.0), 60.0),
        ((-1.0, -math.sqrt(3.0), 0.0), 240.0),
        ((1.0, -1e-18, 0.0), 0.0),  # a hair west of north stays in [0, 360)
    ],
)
def test_course_is_clockwise_from_north(v_ned: tuple[float, float, float], course: float) -> None:
    got = float(course_deg_from_velocity_ned(v_ned))
    assert got == pytest.approx(course, abs=1e-9)
    assert 0.0 <= got < 360.0


def test_course_is_nan_when_hovering_and_vectorised() -> None:
    v = np.array(
        [[0.0, 0.0, 0.0], [0.0, 0.0, 5.0], [COURSE_MIN_SPEED_MPS / 2, 0.0, 0.0], [0, 1, 0]]
    )
    got = course_deg_from_velocity_ned(v)
    assert got.shape == (4,)
    assert np.isnan(got[:3]).all()
    assert got[3] == 90.0
    assert float(course_deg_from_velocity_enu([1.0, 0.0, 0.0])) == pytest.approx(90.0)


@given(st.floats(-50, 50), st.floats(-50, 50))
def test_course_points_along_the_velocity(north: float, east: float) -> None:
    assume(math.hypot(north, east) > COURSE_MIN_SPEED_MPS * 2)
    course = math.radians(float(course_deg_from_velocity_ned([north, east, 0.0])))
    speed = math.hypot(north, east)
    assert math.cos(course) * speed == pytest.approx(north, abs=1e-9)
    assert math.sin(course) * speed == pytest.approx(east, abs=1e-9)


@settings(max_examples=200)
@given(
    lat=st.floats(-89.0, 89.0),
    lon=st.floats(-180.0, 180.0),
    d_lat=st.floats(-0.05, 0.05),
    d_lon=st.floats(-0.05, 0.05),
    alt=st.floats(-500.0, 5000.0),
)
def test_single_point_conversion_equals_the_vectorised_one(
    lat: float, lon: float, d_lat: float, d_lon: float, alt: float
) -> None:
    origin = GeodeticOrigin(lat, lon, 100.0)
    point = (max(-90.0, min(90.0, lat + d_lat)), lon + d_lon, alt)
    expected = geodetic_to_enu(origin, *point)
    assert np.allclose(geodetic_to_enu_point(origin, *point), expected, atol=1e-6, rtol=0)


@settings(max_examples=200)
@given(origin=st.sampled_from(ORIGINS), offset=local_offsets)
def test_single_point_inverse_equals_the_vectorised_one(
    origin: GeodeticOrigin, offset: tuple[float, float, float]
) -> None:
    lat, lon, alt = enu_to_geodetic_point(origin, *offset)
    want_lat, want_lon, want_alt = enu_to_geodetic(origin, np.array(offset))
    assert lat == pytest.approx(float(want_lat), abs=1e-9)
    assert abs((lon - float(want_lon) + 180.0) % 360.0 - 180.0) <= 1e-9  # the same meridian
    assert alt == pytest.approx(float(want_alt), abs=1e-6)
