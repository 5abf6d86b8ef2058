"""6-DoF octorotor dynamics, the paper's equation (2), and a fixed-step RK4 integrator.

Frames and angles
-----------------
World frame = the paper's: ENU (x east, y north, z up; metres). Body frame FLU (forward, left,
up); the thrust acts along body +z. Euler angles ZYX: psi (yaw) about z, theta (pitch) about y,
phi (roll) about x, and ``R = Rz(psi) Ry(theta) Rx(phi)`` maps body to world. psi = 0 faces east.
Positive theta (about body y = left) tilts the nose DOWN, so with psi = 0 the thrust accelerates
the vehicle toward +x (east); positive phi (about forward) lowers the right side and accelerates
toward -y when psi = 0.

State (per vehicle, 12 float64; ``state : (N, 12)``)::

    [x, y, z, vx, vy, vz, phi, theta, psi, p, q, r]
     POS_ENU   VEL_ENU    EULER             BODY_RATES

Inputs: ``thrust_n : (N,)``, ``torque_nm : (N, 3)`` = (tau_phi, tau_theta, tau_psi).

Equation (2) (s, c, t = sin, cos, tan)::

    x''     = (s(theta) c(psi) c(phi) + s(phi) s(psi)) T / m
    y''     = (s(theta) s(psi) c(phi) - s(phi) c(psi)) T / m
    z''     = -g + c(phi) c(theta) T / m
    phi'    = p + q s(phi) t(theta) + r c(phi) t(theta)
    theta'  = q c(phi) - r s(phi)
    psi'    = q s(phi) / c(theta) + r c(phi) / c(theta)
    p'      = (Iyy - Izz) / Ixx q r + l / Ixx tau_phi
    q'      = (Izz - Ixx) / Iyy p r + l / Iyy tau_theta
    r'      = (Ixx - Iyy) / Izz p q + l / Izz tau_psi

The translational terms are ``R[:, 2] T / m - g e_z``. The torque terms are scaled by l / I
exactly as in the paper. The Euler kinematics are singular at theta = +/-90 deg; the controller
limits tilt far below that.

Integration: classic RK4 with the inputs held over the step; psi is wrapped to (-pi, pi] after
each step.

Ground contact (our model, not the paper's): z = 0 is the ground, a perfectly inelastic,
high-friction surface. After each step, a vehicle with z <= 0 is put back on z = 0; if it is not
climbing (vz <= 0, i.e. the vertical thrust component is below m g) it rests: velocity, roll,
pitch and body rates become zero and yaw is kept. A disarmed or landed vehicle therefore sits
still on the ground, and one with vertical thrust above m g lifts off.

Two implementations: numba kernels (``*_into`` per vehicle; :func:`derivative` and
:func:`rk4_step` over all vehicles) and a plain numpy reference vectorised over vehicles
(:func:`derivative_reference`, :func:`rk4_step_reference`) that the tests compare against.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit
from ridsafe.sim_backend.params import OctorotorParams

__all__ = [
    "BODY_RATES",
    "EULER",
    "IDX_P",
    "IDX_PHI",
    "IDX_PSI",
    "IDX_Q",
    "IDX_R",
    "IDX_THETA",
    "IDX_VX",
    "IDX_VY",
    "IDX_VZ",
    "IDX_X",
    "IDX_Y",
    "IDX_Z",
    "POS_ENU",
    "STATE_SIZE",
    "VEL_ENU",
    "OctorotorConsts",
    "derivative",
    "derivative_reference",
    "rk4_step",
    "rk4_step_reference",
    "wrap_angle_rad",
]

FloatArray = NDArray[np.float64]


STATE_SIZE = 12
IDX_X, IDX_Y, IDX_Z = 0, 1, 2
IDX_VX, IDX_VY, IDX_VZ = 3, 4, 5
IDX_PHI, IDX_THETA, IDX_PSI = 6, 7, 8
IDX_P, IDX_Q, IDX_R = 9, 10, 11
POS_ENU = slice(IDX_X, IDX_Z + 1)
VEL_ENU = slice(IDX_VX, IDX_VZ + 1)
EULER = slice(IDX_PHI, IDX_PSI + 1)
BODY_RATES = slice(IDX_P, IDX_R + 1)


class OctorotorConsts(NamedTuple):
    """The airframe as the numba kernels take it (a tuple of floats, SI units)."""

    mass_kg: float
    ixx_kg_m2: float
    iyy_kg_m2: float
    izz_kg_m2: float
    arm_length_m: float
    gravity_m_s2: float
    thrust_min_n: float
    thrust_max_n: float
    torque_max_nm: float

    @classmethod
    def from_params(cls, p: OctorotorParams) -> OctorotorConsts:
        return cls(
            float(p.mass_kg),
            float(p.ixx_kg_m2),
            float(p.iyy_kg_m2),
            float(p.izz_kg_m2),
            float(p.arm_length_m),
            float(p.gravity_m_s2),
            float(p.thrust_min_n),
            float(p.thrust_max_n),
            float(p.torque_max_nm),
        )


@jit
def wrap_angle_rad(a: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    return math.pi - ((math.pi - a) % (2.0 * math.pi))


@jit
def derivative_into(
    s: FloatArray,
    thrust_n: float,
    tau_phi: float,
    tau_theta: float,
    tau_psi: float,
    k: OctorotorConsts,
    out: FloatArray,
) -> None:
    """Equation (2) for one vehicle: ``out = d(s)/dt``; ``s, out : (12,)``."""
    sphi, cphi = math.sin(s[IDX_PHI]), math.cos(s[IDX_PHI])
    sth, cth = math.sin(s[IDX_THETA]), math.cos(s[IDX_THETA])
    spsi, cpsi = math.sin(s[IDX_PSI]), math.cos(s[IDX_PSI])
    p, q, r = s[IDX_P], s[IDX_Q], s[IDX_R]
    t_over_m = thrust_n / k.mass_kg
    out[IDX_X] = s[IDX_VX]
    out[IDX_Y] = s[IDX_VY]
    out[IDX_Z] = s[IDX_VZ]
    out[IDX_VX] = (sth * cpsi * cphi + sphi * spsi) * t_over_m
    out[IDX_VY] = (sth * spsi * cphi - sphi * cpsi) * t_over_m
    out[IDX_VZ] = -k.gravity_m_s2 + cphi * cth * t_over_m
    out[IDX_PHI] = p + (q * sphi + r * cphi) * (sth / cth)
    out[IDX_THETA] = q * cphi - r * sphi
    out[IDX_PSI] = (q * sphi + r * cphi) / cth
    ixx, iyy, izz, arm = k.ixx_kg_m2, k.iyy_kg_m2, k.izz_kg_m2, k.arm_length_m
    out[IDX_P] = (iyy - izz) / ixx * q * r + arm / ixx * tau_phi
    out[IDX_Q] = (izz - ixx) / iyy * p * r + arm / iyy * tau_theta
    out[IDX_R] = (ixx - iyy) / izz * p * q + arm / izz * tau_psi


@jit
def rk4_step_into(
    s: FloatArray,
    thrust_n: float,
    tau_phi: float,
    tau_theta: float,
    tau_psi: float,
    dt_s: float,
    k: OctorotorConsts,
    scratch: FloatArray,
) -> None:
    """One RK4 step of one vehicle, in place; ``scratch : (5, 12)`` is workspace."""
    k1, k2, k3, k4, tmp = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    derivative_into(s, thrust_n, tau_phi, tau_theta, tau_psi, k, k1)
    for j in range(STATE_SIZE):
        tmp[j] = s[j] + 0.5 * dt_s * k1[j]
    derivative_into(tmp, thrust_n, tau_phi, tau_theta, tau_psi, k, k2)
    for j in range(STATE_SIZE):
        tmp[j] = s[j] + 0.5 * dt_s * k2[j]
    derivative_into(tmp, thrust_n, tau_phi, tau_theta, tau_psi, k, k3)
    for j in range(STATE_SIZE):
        tmp[j] = s[j] + dt_s * k3[j]
    derivative_into(tmp, thrust_n, tau_phi, tau_theta, tau_psi, k, k4)
    for j in range(STATE_SIZE):
        s[j] += dt_s / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    s[IDX_PSI] = wrap_angle_rad(s[IDX_PSI])


@jit
def ground_contact_into(s: FloatArray) -> None:
    """Ground contact at z = 0 for one vehicle, in place (see the module docstring)."""
    if s[IDX_Z] > 0.0:
        return
    s[IDX_Z] = 0.0
    if s[IDX_VZ] > 0.0:
        return
    for j in range(IDX_VX, IDX_VZ + 1):
        s[j] = 0.0
    s[IDX_PHI] = 0.0
    s[IDX_THETA] = 0.0
    for j in range(IDX_P, IDX_R + 1):
        s[j] = 0.0


@jit
def _derivative_all(
    state: FloatArray, thrust_n: FloatArray, torque_nm: FloatArray, k: OctorotorConsts
) -> FloatArray:
    out = np.empty_like(state)
    for i in range(state.shape[0]):
        t = torque_nm[i]
        derivative_into(state[i], thrust_n[i], t[0], t[1], t[2], k, out[i])
    return out


@jit
def _rk4_step_all(
    state: FloatArray,
    thrust_n: FloatArray,
    torque_nm: FloatArray,
    dt_s: float,
    k: OctorotorConsts,
    ground_contact: bool,
) -> FloatArray:
    out = state.copy()
    scratch = np.empty((5, STATE_SIZE))
    for i in range(state.shape[0]):
        t = torque_nm[i]
        rk4_step_into(out[i], thrust_n[i], t[0], t[1], t[2], dt_s, k, scratch)
        if ground_contact:
            ground_contact_into(out[i])
    return out


def _as_inputs(
    state: FloatArray, thrust_n: FloatArray, torque_nm: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Validate shapes and return contiguous float64 copies-or-views."""
    s = np.ascontiguousarray(state, dtype=np.float64)
    t = np.ascontiguousarray(thrust_n, dtype=np.float64)
    tau = np.ascontiguousarray(torque_nm, dtype=np.float64)
    n = s.shape[0]
    if s.shape != (n, STATE_SIZE) or t.shape != (n,) or tau.shape != (n, 3):
        raise ValueError(
            f"expected state (N, {STATE_SIZE}), thrust_n (N,), torque_nm (N, 3); "
            f"got {s.shape}, {t.shape}, {tau.shape}"
        )
    return s, t, tau


def derivative(
    state: FloatArray, thrust_n: FloatArray, torque_nm: FloatArray, params: OctorotorParams
) -> FloatArray:
    """Compiled equation (2) for all vehicles: ``(N, 12)`` state derivative."""
    s, t, tau = _as_inputs(state, thrust_n, torque_nm)
    result: FloatArray = _derivative_all(s, t, tau, OctorotorConsts.from_params(params))
    return result


def rk4_step(
    state: FloatArray,
    thrust_n: FloatArray,
    torque_nm: FloatArray,
    dt_s: float,
    params: OctorotorParams,
    *,
    ground_contact: bool = True,
) -> FloatArray:
    """Compiled RK4 step for all vehicles (inputs held); returns the new ``(N, 12)`` state."""
    s, t, tau = _as_inputs(state, thrust_n, torque_nm)
    k = OctorotorConsts.from_params(params)
    result: FloatArray = _rk4_step_all(s, t, tau, float(dt_s), k, ground_contact)
    return result


def derivative_reference(
    state: FloatArray, thrust_n: FloatArray, torque_nm: FloatArray, params: OctorotorParams
) -> FloatArray:
    """Plain-numpy equation (2), vectorised over vehicles (the tests' reference)."""
    phi, theta, psi = state[:, EULER].T
    p, q, r = state[:, BODY_RATES].T
    ixx, iyy, izz = params.ixx_kg_m2, params.iyy_kg_m2, params.izz_kg_m2
    arm = params.arm_length_m
    body_z = np.stack(
        [
            np.sin(theta) * np.cos(psi) * np.cos(phi) + np.sin(phi) * np.sin(psi),
            np.sin(theta) * np.sin(psi) * np.cos(phi) - np.sin(phi) * np.cos(psi),
            np.cos(phi) * np.cos(theta),
        ],
        axis=1,
    )
    accel = body_z * (thrust_n / params.mass_kg)[:, None]
    accel[:, 2] -= params.gravity_m_s2  # the z (up) component
    euler_rates = np.stack(
        [
            p + q * np.sin(phi) * np.tan(theta) + r * np.cos(phi) * np.tan(theta),
            q * np.cos(phi) - r * np.sin(phi),
            q * np.sin(phi) / np.cos(theta) + r * np.cos(phi) / np.cos(theta),
        ],
        axis=1,
    )
    inertia = np.array([ixx, iyy, izz])
    gyro = np.stack([(iyy - izz) * q * r, (izz - ixx) * p * r, (ixx - iyy) * p * q], axis=1)
    rate_dot = (gyro + arm * torque_nm) / inertia
    return np.concatenate([state[:, VEL_ENU], accel, euler_rates, rate_dot], axis=1)


def rk4_step_reference(
    state: FloatArray,
    thrust_n: FloatArray,
    torque_nm: FloatArray,
    dt_s: float,
    params: OctorotorParams,
) -> FloatArray:
    """Plain-numpy RK4 step (no ground contact), psi wrapped to (-pi, pi]."""

    def f(s: FloatArray) -> FloatArray:
        return derivative_reference(s, thrust_n, torque_nm, params)

    k1 = f(state)
    k2 = f(state + 0.5 * dt_s * k1)
    k3 = f(state + 0.5 * dt_s * k2)
    k4 = f(state + dt_s * k3)
    out = state + dt_s / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    out[:, IDX_PSI] = np.pi - np.mod(np.pi - out[:, IDX_PSI], 2.0 * np.pi)
    return out
