r"""Frame conversions: WGS-84 geodetic <-> ECEF <-> local ENU / NED, and sim <-> MAVLink attitude.

This is the one module that changes frames; everything else names its frame in its field names
(``p_enu_m``, ``v_ned_mps``) and calls these functions at the boundary.

Geodetic -> ECEF (WGS-84, a = 6378137 m, f = 1/298.257223563, e^2 = f (2 - f))::

    N(lat) = a / sqrt(1 - e^2 sin^2 lat)
    x = (N + h) cos lat cos lon,   y = (N + h) cos lat sin lon,   z = (N (1 - e^2) + h) sin lat

ECEF -> geodetic: Heikkinen's closed form (Zhu 1993), exact to well below a millimetre near the
Earth's surface; no iteration.

ECEF -> local East-North-Up about an origin (lat0, lon0, h0) with ECEF position p0::

    p_enu = R (p_ecef - p0),   R = [[-sin lon0,           cos lon0,           0       ],
                                    [-sin lat0 cos lon0, -sin lat0 sin lon0,  cos lat0],
                                    [ cos lat0 cos lon0,  cos lat0 sin lon0,  sin lat0]]

and NED = (n, e, -u). These are exact (ECEF-based), not flat-earth: "up" at the origin is the
ellipsoid normal there, and a point 5 km away at the origin's altitude is ~2 m below the
tangent plane.

Attitude. The sim uses world ENU, body FLU (forward-left-up), ZYX Euler angles
(psi yaw about z, then theta pitch about y, then phi roll about x)::

    R_enu_flu = Rz(psi) Ry(theta) Rx(phi),    psi = 0 facing east, theta > 0 = nose DOWN

MAVLink uses world NED, body FRD (forward-right-down), the same ZYX order::

    R_ned_frd = Rz(yaw) Ry(pitch) Rx(roll),   yaw = 0 facing north, clockwise; pitch > 0 = nose up

With T = [[0,1,0],[1,0,0],[0,0,-1]] (ENU <-> NED, its own inverse) and D = diag(1,-1,-1)
(FLU <-> FRD), R_ned_frd = T R_enu_flu D, which works out to::

    roll = phi,   pitch = -theta,   yaw = wrap(pi/2 - psi)
    p_frd = p,    q_frd = -q,       r_frd = -r           (body rates: omega_frd = D omega_flu)

and the inverse phi = roll, theta = -pitch, psi = wrap(pi/2 - yaw). The tests check this against
rotation matrices built independently (scipy), not against these formulas.

Course: ``atan2(v_east, v_north)`` in degrees, [0, 360), clockwise from north; NaN below
:data:`COURSE_MIN_SPEED_MPS` horizontal speed (never ``arccos``, which only spans 0-180 deg).

Shapes: position functions take latitude/longitude/altitude of any broadcastable shape S
(scalars, (N,)) and return (*S, 3) float64; the inverses take (..., 3) and return three arrays
of shape (...). Attitude functions accept floats or arrays (elementwise) and return the same kind.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.errors import FieldValueError
from ridsafe.common.jit import jit

__all__ = [
    "COURSE_MIN_SPEED_MPS",
    "WGS84_A_M",
    "WGS84_E2",
    "WGS84_F",
    "GeodeticOrigin",
    "attitude_mavlink_to_sim",
    "attitude_sim_to_mavlink",
    "body_rates_flu_to_frd",
    "body_rates_frd_to_flu",
    "course_deg_from_velocity_enu",
    "course_deg_from_velocity_ned",
    "cov_enu_to_ned",
    "cov_ned_to_enu",
    "ecef_to_geodetic",
    "enu_to_geodetic",
    "enu_to_geodetic_point",
    "enu_to_ned",
    "geodetic_to_ecef",
    "geodetic_to_enu",
    "geodetic_to_enu_point",
    "geodetic_to_ned",
    "ned_to_enu",
    "ned_to_geodetic",
    "wrap_pi",
]

FloatArray = NDArray[np.float64]
#: A float or an array of floats; attitude helpers return the kind they were given.
A = TypeVar("A", float, FloatArray)

WGS84_A_M = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
_WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)
_WGS84_EP2 = (WGS84_A_M**2 - _WGS84_B_M**2) / _WGS84_B_M**2  # second eccentricity squared

#: Below this horizontal speed the course is undefined and reported as NaN.
COURSE_MIN_SPEED_MPS = 0.01


@dataclass(frozen=True)
class GeodeticOrigin:
    """The origin of a local ENU/NED frame: WGS-84 latitude, longitude (deg), ellipsoid height (m).

    Raises :class:`~ridsafe.common.errors.FieldValueError` (a ValueError) for |lat| > 90,
    |lon| > 180 or non-finite values.
    """

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0

    def __post_init__(self) -> None:
        for name, limit in (("lat_deg", 90.0), ("lon_deg", 180.0), ("alt_m", math.inf)):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise FieldValueError(name, f"expected a finite number, got {value!r}")
            if abs(value) > limit:
                raise FieldValueError(name, f"expected |{name}| <= {limit:g}, got {value!r}")


# --------------------------------------------------------------------------------------------
# Geodetic <-> ECEF


def geodetic_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike) -> FloatArray:
    """WGS-84 geodetic -> ECEF metres. Inputs broadcast to shape S; returns (*S, 3)."""
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    h = np.asarray(alt_m, dtype=np.float64)
    sin_lat = np.sin(lat)
    n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * sin_lat**2)
    r_xy = (n + h) * np.cos(lat)
    x = r_xy * np.cos(lon)
    y = r_xy * np.sin(lon)
    z = (n * (1.0 - WGS84_E2) + h) * sin_lat
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def ecef_to_geodetic(p_ecef_m: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """ECEF metres (..., 3) -> (lat_deg, lon_deg, alt_m), each of shape (...).

    Heikkinen's closed form; longitude in (-180, 180]. Valid away from the Earth's centre
    (anywhere an aircraft can be). Compiled (:func:`_ecef_to_geodetic_kernel`): the sim
    converts its whole fleet at every position report, where two dozen numpy calls on a
    few elements each cost ten times the arithmetic.
    """
    p = np.asarray(p_ecef_m, dtype=np.float64)
    flat = np.ascontiguousarray(p.reshape(-1, 3))
    out = np.empty((3, flat.shape[0]))
    _ecef_to_geodetic_kernel(flat, out)
    shape = p.shape[:-1]  # [()]: a point's values as numpy scalars, as the ufuncs gave
    return out[0].reshape(shape)[()], out[1].reshape(shape)[()], out[2].reshape(shape)[()]


@jit
def _ecef_to_geodetic_kernel(p: FloatArray, out: FloatArray) -> None:
    """Rows of ``p`` (n, 3) ECEF -> ``out`` (3, n): lat deg, lon deg, alt m."""
    a, b, e2 = WGS84_A_M, _WGS84_B_M, WGS84_E2
    for i in range(p.shape[0]):
        x, y, z = p[i, 0], p[i, 1], p[i, 2]
        r_xy = math.hypot(x, y)
        f_term = 54.0 * b**2 * z**2
        g = r_xy**2 + (1.0 - e2) * z**2 - e2 * (a**2 - b**2)
        c = e2**2 * f_term * r_xy**2 / g**3
        s = np.cbrt(1.0 + c + math.sqrt(c**2 + 2.0 * c))
        k = s + 1.0 + 1.0 / s
        pp = f_term / (3.0 * k**2 * g**2)
        q = math.sqrt(1.0 + 2.0 * e2**2 * pp)
        r0_sq = (
            0.5 * a**2 * (1.0 + 1.0 / q)
            - pp * (1.0 - e2) * z**2 / (q * (1.0 + q))
            - 0.5 * pp * r_xy**2
        )
        r0 = -pp * e2 * r_xy / (1.0 + q) + math.sqrt(max(r0_sq, 0.0))
        u = math.hypot(r_xy - e2 * r0, z)
        v = math.sqrt((r_xy - e2 * r0) ** 2 + (1.0 - e2) * z**2)
        z0 = b**2 * z / (a * v)
        out[2, i] = u * (1.0 - b**2 / (a * v))
        out[0, i] = math.degrees(math.atan2(z + _WGS84_EP2 * z0, r_xy))
        out[1, i] = math.degrees(math.atan2(y, x))


# --------------------------------------------------------------------------------------------
# Geodetic <-> local ENU / NED


@functools.cache
def _origin_frame(origin: GeodeticOrigin) -> tuple[FloatArray, FloatArray]:
    """(ECEF position of the origin (3,), rotation ECEF -> ENU (3, 3)), both read-only."""
    p0 = geodetic_to_ecef(origin.lat_deg, origin.lon_deg, origin.alt_m)
    lat, lon = math.radians(origin.lat_deg), math.radians(origin.lon_deg)
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    r = np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])
    p0.setflags(write=False)
    r.setflags(write=False)
    return p0, r


def geodetic_to_enu(
    origin: GeodeticOrigin, lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike
) -> FloatArray:
    """Geodetic -> local ENU metres about ``origin``. Inputs broadcast to S; returns (*S, 3)."""
    p0, r = _origin_frame(origin)
    d = geodetic_to_ecef(lat_deg, lon_deg, alt_m) - p0
    p_enu: FloatArray = np.einsum("ij,...j->...i", r, d)
    return p_enu


def enu_to_geodetic(
    origin: GeodeticOrigin, p_enu_m: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Local ENU metres (..., 3) about ``origin`` -> (lat_deg, lon_deg, alt_m), each (...)."""
    p0, r = _origin_frame(origin)
    p_ecef = np.einsum("ji,...j->...i", r, np.asarray(p_enu_m, dtype=np.float64)) + p0
    return ecef_to_geodetic(p_ecef)


def geodetic_to_enu_point(
    origin: GeodeticOrigin, lat_deg: float, lon_deg: float, alt_m: float
) -> tuple[float, float, float]:
    """One point, geodetic -> local ENU metres about ``origin``: the same equations as
    :func:`geodetic_to_enu` in plain floats, ~10x faster for a single point (the per-message
    conversions of the GCS and the companions)."""
    p0, r = _origin_frame_tuples(origin)
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    sin_lat = math.sin(lat)
    n = WGS84_A_M / math.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
    r_xy = (n + alt_m) * math.cos(lat)
    d = (
        r_xy * math.cos(lon) - p0[0],
        r_xy * math.sin(lon) - p0[1],
        (n * (1.0 - WGS84_E2) + alt_m) * sin_lat - p0[2],
    )
    return (
        r[0][0] * d[0] + r[0][1] * d[1] + r[0][2] * d[2],
        r[1][0] * d[0] + r[1][1] * d[1] + r[1][2] * d[2],
        r[2][0] * d[0] + r[2][1] * d[1] + r[2][2] * d[2],
    )


def enu_to_geodetic_point(
    origin: GeodeticOrigin, east_m: float, north_m: float, up_m: float
) -> tuple[float, float, float]:
    """One point, local ENU metres about ``origin`` -> (lat_deg, lon_deg, alt_m): the same
    equations as :func:`enu_to_geodetic` (Heikkinen) in plain floats, ~10x faster for a
    single point (a planner target, a region centre)."""
    p0, r = _origin_frame_tuples(origin)
    x = r[0][0] * east_m + r[1][0] * north_m + r[2][0] * up_m + p0[0]
    y = r[0][1] * east_m + r[1][1] * north_m + r[2][1] * up_m + p0[1]
    z = r[0][2] * east_m + r[1][2] * north_m + r[2][2] * up_m + p0[2]
    a, b, e2 = WGS84_A_M, _WGS84_B_M, WGS84_E2
    r_xy = math.hypot(x, y)
    f_term = 54.0 * b * b * z * z
    g = r_xy * r_xy + (1.0 - e2) * z * z - e2 * (a * a - b * b)
    c = e2 * e2 * f_term * r_xy * r_xy / g**3
    s = (1.0 + c + math.sqrt(c * c + 2.0 * c)) ** (1.0 / 3.0)
    k = s + 1.0 + 1.0 / s
    pp = f_term / (3.0 * k * k * g * g)
    q = math.sqrt(1.0 + 2.0 * e2 * e2 * pp)
    r0_sq = (
        0.5 * a * a * (1.0 + 1.0 / q)
        - pp * (1.0 - e2) * z * z / (q * (1.0 + q))
        - 0.5 * pp * r_xy * r_xy
    )
    r0 = -pp * e2 * r_xy / (1.0 + q) + math.sqrt(max(r0_sq, 0.0))
    u = math.hypot(r_xy - e2 * r0, z)
    v = math.sqrt((r_xy - e2 * r0) ** 2 + (1.0 - e2) * z * z)
    z0 = b * b * z / (a * v)
    alt = u * (1.0 - b * b / (a * v))
    lat = math.degrees(math.atan2(z + _WGS84_EP2 * z0, r_xy))
    return lat, math.degrees(math.atan2(y, x)), alt


@functools.cache
def _origin_frame_tuples(
    origin: GeodeticOrigin,
) -> tuple[tuple[float, ...], tuple[tuple[float, ...], ...]]:
    p0, r = _origin_frame(origin)
    return tuple(p0.tolist()), tuple(tuple(row) for row in r.tolist())


def geodetic_to_ned(
    origin: GeodeticOrigin, lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike
) -> FloatArray:
    """Geodetic -> local NED metres about ``origin``. Inputs broadcast to S; returns (*S, 3)."""
    return enu_to_ned(geodetic_to_enu(origin, lat_deg, lon_deg, alt_m))


def ned_to_geodetic(
    origin: GeodeticOrigin, p_ned_m: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Local NED metres (..., 3) about ``origin`` -> (lat_deg, lon_deg, alt_m), each (...)."""
    return enu_to_geodetic(origin, ned_to_enu(p_ned_m))


def enu_to_ned(v_enu: ArrayLike) -> FloatArray:
    """ENU vector(s) (..., 3) -> NED (..., 3): (e, n, u) -> (n, e, -u). A new array."""
    v = np.asarray(v_enu, dtype=np.float64)
    return np.stack((v[..., 1], v[..., 0], -v[..., 2]), axis=-1)


def ned_to_enu(v_ned: ArrayLike) -> FloatArray:
    """NED vector(s) (..., 3) -> ENU (..., 3): (n, e, d) -> (e, n, -d). A new array."""
    v = np.asarray(v_ned, dtype=np.float64)
    return np.stack((v[..., 1], v[..., 0], -v[..., 2]), axis=-1)


#: ENU <-> NED as index permutation and signs: (e, n, u) -> (n, e, -u), T = its matrix.
_SWAP_EN = [1, 0, 2]
_FLIP_UP = np.array([1.0, 1.0, -1.0])


def cov_enu_to_ned(cov_enu: ArrayLike) -> FloatArray:
    """ENU covariance(s) (..., 3, 3) -> NED: T P T^T, T = [[0, 1, 0], [1, 0, 0], [0, 0, -1]].
    Done as the permutation and sign flips it is (exact, no products). A new array."""
    c = np.asarray(cov_enu, dtype=np.float64)
    out: FloatArray = c[..., _SWAP_EN, :][..., _SWAP_EN] * (_FLIP_UP[:, None] * _FLIP_UP)
    return out


def cov_ned_to_enu(cov_ned: ArrayLike) -> FloatArray:
    """NED covariance(s) (..., 3, 3) -> ENU: T P T^T (T is its own inverse). A new array."""
    return cov_enu_to_ned(cov_ned)


# --------------------------------------------------------------------------------------------
# Attitude: sim (ENU world, FLU body) <-> MAVLink (NED world, FRD body)


def wrap_pi(angle_rad: A) -> A:
    """Wrap angle(s) in radians to [-pi, pi)."""
    return (angle_rad + math.pi) % math.tau - math.pi


def attitude_sim_to_mavlink(phi: A, theta: A, psi: A) -> tuple[A, A, A]:
    """Sim ZYX Euler (ENU/FLU, rad) -> MAVLink ``(roll, pitch, yaw)`` (NED/FRD, rad).

    roll = phi, pitch = -theta, yaw = wrap(pi/2 - psi) in [-pi, pi).
    """
    return phi, -theta, wrap_pi(math.pi / 2 - psi)


def attitude_mavlink_to_sim(roll: A, pitch: A, yaw: A) -> tuple[A, A, A]:
    """MAVLink ``(roll, pitch, yaw)`` (NED/FRD, rad) -> sim ZYX Euler ``(phi, theta, psi)``.

    phi = roll, theta = -pitch, psi = wrap(pi/2 - yaw) in [-pi, pi).
    """
    return roll, -pitch, wrap_pi(math.pi / 2 - yaw)


def body_rates_flu_to_frd(p: A, q: A, r: A) -> tuple[A, A, A]:
    """Body rates about FLU axes (rad/s) -> about FRD axes: (p, -q, -r)."""
    return p, -q, -r


def body_rates_frd_to_flu(p: A, q: A, r: A) -> tuple[A, A, A]:
    """Body rates about FRD axes (rad/s) -> about FLU axes: (p, -q, -r)."""
    return p, -q, -r


# --------------------------------------------------------------------------------------------
# Course over ground


def course_deg_from_velocity_ned(v_ned_mps: ArrayLike) -> FloatArray:
    """Course over ground in degrees [0, 360), clockwise from north, from NED velocity (..., 3).

    Returns shape (...). NaN where the horizontal speed is below :data:`COURSE_MIN_SPEED_MPS`
    (hovering has no course; the Remote ID encoder maps NaN to "unknown").
    """
    v = np.asarray(v_ned_mps, dtype=np.float64)
    north, east = v[..., 0], v[..., 1]
    course = np.degrees(np.arctan2(east, north)) % 360.0
    course = np.where(course >= 360.0, 0.0, course)  # -1e-17 % 360 rounds to 360.0
    return np.where(np.hypot(north, east) < COURSE_MIN_SPEED_MPS, np.nan, course)


def course_deg_from_velocity_enu(v_enu_mps: ArrayLike) -> FloatArray:
    """As :func:`course_deg_from_velocity_ned`, from an ENU velocity (..., 3)."""
    return course_deg_from_velocity_ned(enu_to_ned(v_enu_mps))
