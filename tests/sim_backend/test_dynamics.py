"""Equation (2) and RK4 against hand-derived expectations and the numpy reference."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.sim_backend.dynamics import (
    BODY_RATES,
    EULER,
    IDX_P,
    IDX_PHI,
    IDX_PSI,
    IDX_Q,
    IDX_R,
    IDX_THETA,
    IDX_VX,
    IDX_VY,
    IDX_VZ,
    IDX_X,
    IDX_Y,
    IDX_Z,
    POS_ENU,
    STATE_SIZE,
    VEL_ENU,
    derivative,
    derivative_reference,
    rk4_step,
    rk4_step_reference,
    wrap_angle_rad,
)
from ridsafe.sim_backend.params import OctorotorParams

FloatArray = NDArray[np.float64]
Derivative = Callable[[FloatArray, FloatArray, FloatArray, OctorotorParams], FloatArray]

PAPER = OctorotorParams()
# Three different inertias, so every gyroscopic term is nonzero and a swapped index shows.
ASYMMETRIC = OctorotorParams(ixx_kg_m2=0.3, iyy_kg_m2=0.5, izz_kg_m2=0.9)
IMPLEMENTATIONS = pytest.mark.parametrize(
    "deriv", [derivative, derivative_reference], ids=["numba", "numpy"]
)


def _state(**values: float) -> FloatArray:
    """One vehicle's ``(1, 12)`` state from named components (x, vx, phi, p, ...)."""
    index = {
        "x": IDX_X, "y": IDX_Y, "z": IDX_Z, "vx": IDX_VX, "vy": IDX_VY, "vz": IDX_VZ,
        "phi": IDX_PHI, "theta": IDX_THETA, "psi": IDX_PSI, "p": IDX_P, "q": IDX_Q, "r": IDX_R,
    }  # fmt: skip
    s = np.zeros((1, STATE_SIZE))
    for name, value in values.items():
        s[0, index[name]] = value
    return s


def _rot_x(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _fly(
    state: FloatArray, thrust_n: float, seconds: float, dt_s: float, *, ground: bool
) -> FloatArray:
    thrust = np.array([thrust_n])
    torque = np.zeros((1, 3))
    for _ in range(round(seconds / dt_s)):
        state = rk4_step(state, thrust, torque, dt_s, PAPER, ground_contact=ground)
    return state


def test_hover_thrust_holds_altitude() -> None:
    end = _fly(_state(x=3.0, y=-2.0, z=50.0), PAPER.weight_n, 10.0, 0.0025, ground=True)
    np.testing.assert_allclose(end[0, POS_ENU], [3.0, -2.0, 50.0], atol=1e-9)
    np.testing.assert_allclose(end[0, VEL_ENU], 0.0, atol=1e-9)


def test_free_fall_follows_closed_form() -> None:
    z0, t = 1000.0, 5.0
    end = _fly(_state(z=z0, vx=1.5), 0.0, t, 0.0025, ground=False)
    g = PAPER.gravity_m_s2
    assert end[0, IDX_Z] == pytest.approx(z0 - 0.5 * g * t**2, abs=1e-9)
    assert end[0, IDX_VZ] == pytest.approx(-g * t, abs=1e-9)
    assert end[0, IDX_X] == pytest.approx(1.5 * t, abs=1e-9)


@IMPLEMENTATIONS
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_torque_gives_l_tau_over_inertia(deriv: Derivative, axis: int) -> None:
    torque = np.zeros((1, 3))
    torque[0, axis] = 37.0
    d = deriv(_state(z=10.0), np.array([100.0]), torque, ASYMMETRIC)
    inertia = [ASYMMETRIC.ixx_kg_m2, ASYMMETRIC.iyy_kg_m2, ASYMMETRIC.izz_kg_m2][axis]
    expected = np.zeros(3)
    expected[axis] = ASYMMETRIC.arm_length_m * 37.0 / inertia
    np.testing.assert_allclose(d[0, BODY_RATES], expected, rtol=1e-14, atol=1e-14)


@IMPLEMENTATIONS
@pytest.mark.parametrize(
    "phi, theta, psi", [(0.3, -0.2, 1.1), (-0.45, 0.35, -2.4), (0.1, 0.5, 2.9), (0.6, 0.0, 0.7)]
)
def test_translational_acceleration_is_body_z_thrust_minus_gravity(
    deriv: Derivative, phi: float, theta: float, psi: float
) -> None:
    thrust = 180.0
    d = deriv(_state(phi=phi, theta=theta, psi=psi), np.array([thrust]), np.zeros((1, 3)), PAPER)
    rotation = _rot_z(psi) @ _rot_y(theta) @ _rot_x(phi)
    expected = rotation @ np.array([0.0, 0.0, thrust / PAPER.mass_kg])
    expected[2] -= PAPER.gravity_m_s2
    np.testing.assert_allclose(d[0, VEL_ENU], expected, rtol=1e-13, atol=1e-13)


def test_swapped_sin_cos_in_y_or_z_would_fail_the_acceleration_test() -> None:
    """The rotation-matrix oracle is sensitive to the swaps seen in public code of this model."""
    phi, theta, psi, t_over_m = 0.3, -0.2, 1.1, 180.0 / PAPER.mass_kg
    oracle = (_rot_z(psi) @ _rot_y(theta) @ _rot_x(phi))[:, 2] * t_over_m
    sp, cp, st, _ct, ss, cs = (f(a) for a in (phi, theta, psi) for f in (math.sin, math.cos))
    wrong_y = (st * cs * cp - sp * ss) * t_over_m  # psi's sin and cos exchanged
    wrong_z = cp * st * t_over_m  # cos(theta) replaced by sin(theta)
    assert abs(wrong_y - oracle[1]) > 0.1  # the oracle test holds to 1e-13
    assert abs(wrong_z - oracle[2]) > 0.1


@IMPLEMENTATIONS
def test_sign_conventions_enu_flu(deriv: Derivative) -> None:
    """+theta at psi=0 pushes east; +phi pushes south (-y); +theta facing north pushes north."""
    thrust, none = np.array([150.0]), np.zeros((1, 3))
    pitch_east = deriv(_state(theta=0.2), thrust, none, PAPER)[0, VEL_ENU]
    roll = deriv(_state(phi=0.2), thrust, none, PAPER)[0, VEL_ENU]
    pitch_north = deriv(_state(theta=0.2, psi=math.pi / 2), thrust, none, PAPER)[0, VEL_ENU]
    assert pitch_east[0] > 1.0 and abs(pitch_east[1]) < 1e-12
    assert roll[1] < -1.0 and abs(roll[0]) < 1e-12
    assert pitch_north[1] > 1.0 and abs(pitch_north[0]) < 1e-12


@IMPLEMENTATIONS
def test_gyroscopic_coupling(deriv: Derivative) -> None:
    p, q, r = 0.7, -1.3, 2.1
    d = deriv(_state(p=p, q=q, r=r), np.array([100.0]), np.zeros((1, 3)), ASYMMETRIC)
    ixx, iyy, izz = 0.3, 0.5, 0.9
    expected = [(iyy - izz) / ixx * q * r, (izz - ixx) / iyy * p * r, (ixx - iyy) / izz * p * q]
    np.testing.assert_allclose(d[0, BODY_RATES], expected, rtol=1e-14)


@IMPLEMENTATIONS
def test_euler_kinematics(deriv: Derivative) -> None:
    phi, theta, p, q, r = 0.2, -0.3, 0.4, -0.5, 0.6
    d = deriv(
        _state(phi=phi, theta=theta, p=p, q=q, r=r), np.array([100.0]), np.zeros((1, 3)), PAPER
    )
    sp, cp, tt, ct = math.sin(phi), math.cos(phi), math.tan(theta), math.cos(theta)
    expected = [p + q * sp * tt + r * cp * tt, q * cp - r * sp, q * sp / ct + r * cp / ct]
    np.testing.assert_allclose(d[0, EULER], expected, rtol=1e-14)


def _random_inputs(rng: np.random.Generator, n: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    state = rng.normal(0.0, 5.0, size=(n, STATE_SIZE))
    state[:, EULER] = rng.uniform([-1.2, -1.2, -math.pi], [1.2, 1.2, math.pi], size=(n, 3))
    state[:, BODY_RATES] = rng.normal(0.0, 2.0, size=(n, 3))
    thrust = rng.uniform(0.0, 500.0, size=n)
    torque = rng.uniform(-150.0, 150.0, size=(n, 3))
    return state, thrust, torque


def test_compiled_derivative_equals_numpy_reference() -> None:
    state, thrust, torque = _random_inputs(np.random.default_rng(20240611), 64)
    np.testing.assert_allclose(
        derivative(state, thrust, torque, ASYMMETRIC),
        derivative_reference(state, thrust, torque, ASYMMETRIC),
        rtol=1e-12,
        atol=1e-12,
    )


def test_compiled_rk4_equals_numpy_reference() -> None:
    state, thrust, torque = _random_inputs(np.random.default_rng(7), 64)
    state[:, IDX_Z] = 100.0
    compiled = rk4_step(state, thrust, torque, 0.0025, ASYMMETRIC)
    reference = rk4_step_reference(state, thrust, torque, 0.0025, ASYMMETRIC)
    np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-12)


def test_rk4_is_fourth_order() -> None:
    """Halving dt on a smooth tumbling climb cuts the error about 2^4 = 16 times."""
    start = _state(z=100.0, vx=2.0, phi=0.1, theta=-0.2, psi=0.4, p=0.6, q=-0.4, r=0.8)
    thrust, torque = np.array([160.0]), np.array([[0.8, -0.5, 0.3]])

    def integrate(dt_s: float) -> FloatArray:
        s = start.copy()
        for _ in range(round(1.0 / dt_s)):
            s = rk4_step(s, thrust, torque, dt_s, ASYMMETRIC, ground_contact=False)
        return s

    truth = integrate(1.0 / 1280)
    err_coarse = np.abs(integrate(1.0 / 20) - truth).max()
    err_fine = np.abs(integrate(1.0 / 40) - truth).max()
    assert err_coarse > 1e-9
    assert 13.0 < err_coarse / err_fine < 19.0


def test_yaw_is_wrapped_to_half_open_interval() -> None:
    end = rk4_step(
        _state(z=10.0, psi=3.1, r=1.0), np.array([PAPER.weight_n]), np.zeros((1, 3)), 0.1, PAPER
    )
    assert end[0, IDX_PSI] == pytest.approx(3.1 + 0.1 - 2.0 * math.pi, abs=1e-9)
    assert wrap_angle_rad(math.pi) == math.pi
    assert wrap_angle_rad(-math.pi) == math.pi
    assert wrap_angle_rad(3.0 * math.pi) == pytest.approx(math.pi)
    assert wrap_angle_rad(-0.5) == -0.5


def test_ground_contact_brings_a_falling_vehicle_to_rest() -> None:
    start = _state(z=2.0, vx=3.0, vy=-1.0, vz=-1.0, phi=0.2, theta=-0.1, psi=0.7, p=0.3, r=-0.2)
    end = _fly(start, 0.0, 2.0, 0.0025, ground=True)
    expected = _state(x=end[0, IDX_X], y=end[0, IDX_Y], psi=end[0, IDX_PSI])
    np.testing.assert_array_equal(end, expected)
    assert end[0, IDX_PSI] != 0.0  # heading kept


def test_vehicle_on_ground_rests_below_weight_and_lifts_above() -> None:
    resting = _fly(_state(), 0.9 * PAPER.weight_n, 1.0, 0.0025, ground=True)
    np.testing.assert_array_equal(resting, _state())
    lifting = _fly(_state(), 1.1 * PAPER.weight_n, 1.0, 0.0025, ground=True)
    expected_z = 0.5 * (1.1 * PAPER.gravity_m_s2 - PAPER.gravity_m_s2) * 1.0**2
    assert lifting[0, IDX_Z] == pytest.approx(expected_z, rel=1e-9)


def test_wrong_shapes_are_rejected() -> None:
    with pytest.raises(ValueError, match="thrust_n"):
        rk4_step(np.zeros((2, STATE_SIZE)), np.zeros(3), np.zeros((2, 3)), 0.01, PAPER)
