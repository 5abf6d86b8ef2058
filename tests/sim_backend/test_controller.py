"""Closed-loop step responses of the cascaded controller on the eq. (2) octorotor.

Every flight is sampled at every controller period (100 Hz) and the limits are checked at every
sample: horizontal speed <= 8 m/s, tilt <= 30 deg, climb <= 2.5 m/s, descent <= 1.5 m/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.sim_backend.actuation import thrust_levels_n, torque_levels_nm
from ridsafe.sim_backend.controller import shaped_speed
from ridsafe.sim_backend.dynamics import (
    IDX_PHI,
    IDX_PSI,
    IDX_R,
    IDX_THETA,
    IDX_VX,
    IDX_VY,
    IDX_VZ,
    IDX_X,
    IDX_Z,
    POS_ENU,
    STATE_SIZE,
    VEL_ENU,
)
from ridsafe.sim_backend.params import ControllerParams, OctorotorParams
from ridsafe.sim_backend.vehicles import OctorotorFleet

FloatArray = NDArray[np.float64]

CTRL = ControllerParams()
QUANTISED = ControllerParams(quantise_to_action_set=True)
HOVER_50M = (0.0, 0.0, 50.0)
# Tolerances on the limits, sample by sample (speed in m/s, tilt in deg). Quantised commands
# (torque steps of 50 N m held for 10 ms) make the attitude and speeds jitter a little more.
SPEED_TOL, TILT_TOL_DEG = 0.01, 0.05
QUANTISED_SPEED_TOL, QUANTISED_TILT_TOL_DEG = 0.05, 0.5


@dataclass(frozen=True)
class Flight:
    """One vehicle's flight sampled after every controller period."""

    t_s: FloatArray  # (n,)
    state: FloatArray  # (n, 12)
    thrust_n: FloatArray  # (n,)
    torque_nm: FloatArray  # (n, 3)

    @property
    def speed_xy(self) -> FloatArray:
        return np.hypot(self.state[:, IDX_VX], self.state[:, IDX_VY])

    @property
    def tilt_deg(self) -> FloatArray:
        cos_tilt = np.cos(self.state[:, IDX_PHI]) * np.cos(self.state[:, IDX_THETA])
        tilt: FloatArray = np.degrees(np.arccos(np.clip(cos_tilt, -1.0, 1.0)))
        return tilt

    def settle_time_s(self, target: FloatArray, radius_m: float) -> float:
        """First time after which the vehicle stays within ``radius_m`` of ``target``."""
        outside = np.linalg.norm(self.state[:, POS_ENU] - target, axis=1) > radius_m
        assert not outside[-1], "never settled"
        last_out = np.flatnonzero(outside)
        return float(self.t_s[last_out[-1] + 1]) if last_out.size else float(self.t_s[0])


@pytest.mark.parametrize("d", [0.0, 0.3, 2.4999, 2.5, 2.5001, 7.0, 40.0])
def test_square_root_shaper_is_continuous_with_the_right_slope(d: float) -> None:
    """speed = k d up to a / k^2 = 2.5 m, sqrt(2 a (d - a / 2 k^2)) beyond; slope = d speed/dd."""
    gain, decel, h = 1.0, 2.5, 1e-6
    speed, slope = shaped_speed(d, gain, decel)
    expected = gain * d if d <= 2.5 else math.sqrt(2 * decel * (d - 1.25))
    assert speed == pytest.approx(expected, rel=1e-12, abs=1e-12)
    numeric = (
        shaped_speed(d + h, gain, decel)[0] - shaped_speed(max(d - h, 0.0), gain, decel)[0]
    ) / (d + h - max(d - h, 0.0))
    assert slope == pytest.approx(numeric, rel=1e-4)


def _fleet(
    start: tuple[float, ...] = HOVER_50M, psi: float = 0.0, ctrl: ControllerParams = CTRL
) -> OctorotorFleet:
    s0 = np.zeros(STATE_SIZE)
    s0[POS_ENU] = start
    s0[IDX_PSI] = psi
    fleet = OctorotorFleet(1, controller=ctrl, initial_state=s0[None, :])
    fleet.arm(0)
    fleet.set_target(0, position_enu_m=start)
    return fleet


def _fly(
    fleet: OctorotorFleet,
    seconds: float,
    each_period: Callable[[OctorotorFleet], None] | None = None,
) -> Flight:
    n = round(seconds * fleet.controller.controller_hz)
    t, state = np.empty(n), np.empty((n, STATE_SIZE))
    thrust, torque = np.empty(n), np.empty((n, 3))
    for k in range(n):
        if each_period is not None:
            each_period(fleet)
        fleet.advance(1)
        t[k], state[k] = fleet.t_s, fleet.state_of(0)
        th, tq = fleet.last_command
        thrust[k], torque[k] = th[0], tq[0]
    return Flight(t, state, thrust, torque)


def _assert_within_limits(
    flight: Flight,
    ctrl: ControllerParams = CTRL,
    speed_tol: float = SPEED_TOL,
    tilt_tol: float = TILT_TOL_DEG,
) -> None:
    assert flight.speed_xy.max() <= ctrl.max_speed_m_s + speed_tol
    assert flight.tilt_deg.max() <= ctrl.max_tilt_deg + tilt_tol
    assert flight.state[:, IDX_VZ].max() <= ctrl.max_climb_m_s + speed_tol
    assert flight.state[:, IDX_VZ].min() >= -ctrl.max_descent_m_s - speed_tol


@pytest.mark.parametrize(
    "offset, settle_bound_s",
    [((80.0, -60.0, 10.0), 16.0), ((-30.0, 45.0, -8.0), 10.0), ((0.0, 120.0, 0.0), 18.0)],
)
def test_position_step_settles_fast_without_overshoot(
    offset: tuple[float, float, float], settle_bound_s: float
) -> None:
    start = np.array(HOVER_50M)
    target = start + offset
    fleet = _fleet()
    fleet.set_target(0, position_enu_m=target)
    flight = _fly(fleet, settle_bound_s + 4.0)
    assert flight.settle_time_s(target, 1.0) <= settle_bound_s
    direction = (target - start) / np.linalg.norm(target - start)
    progress = (flight.state[:, POS_ENU] - start) @ direction
    assert progress.max() - np.linalg.norm(target - start) <= 0.05  # overshoot (m)
    _assert_within_limits(flight)
    assert flight.speed_xy.max() >= CTRL.max_speed_m_s - 0.05  # long steps cruise at the limit


def test_short_step_overshoot_is_small() -> None:
    fleet = _fleet()
    fleet.set_target(0, position_enu_m=(5.0, 0.0, 50.0))
    flight = _fly(fleet, 6.0)
    assert flight.state[:, IDX_X].max() - 5.0 <= 0.05
    assert flight.settle_time_s(np.array([5.0, 0.0, 50.0]), 0.1) <= 5.0
    _assert_within_limits(flight)


@pytest.mark.parametrize("dz, settle_bound_s", [(20.0, 10.0), (-20.0, 15.0)])
def test_vertical_step_respects_climb_and_descent_limits(dz: float, settle_bound_s: float) -> None:
    target = np.array([0.0, 0.0, 50.0 + dz])
    fleet = _fleet()
    fleet.set_target(0, position_enu_m=target)
    flight = _fly(fleet, settle_bound_s + 2.0)
    assert flight.settle_time_s(target, 0.2) <= settle_bound_s
    beyond = np.sign(dz) * (flight.state[:, IDX_Z] - target[2])
    assert beyond.max() <= 0.05
    _assert_within_limits(flight)
    limit = CTRL.max_climb_m_s if dz > 0 else CTRL.max_descent_m_s
    assert np.abs(flight.state[:, IDX_VZ]).max() >= limit - 0.05


def test_velocity_target_is_tracked() -> None:
    wished = np.array([3.0, -4.0, 1.0])
    fleet = _fleet()
    fleet.set_target(0, velocity_enu_m_s=wished)
    flight = _fly(fleet, 8.0)
    after_3s = flight.t_s >= 3.0
    assert np.abs(flight.state[after_3s][:, VEL_ENU] - wished).max() <= 0.1
    _assert_within_limits(flight)


def test_velocity_target_beyond_limits_is_clipped_keeping_direction() -> None:
    fleet = _fleet()
    fleet.set_target(0, velocity_enu_m_s=(12.0, 9.0, 4.0))
    flight = _fly(fleet, 8.0)
    _assert_within_limits(flight)
    end = flight.state[-1]
    np.testing.assert_allclose(end[VEL_ENU], [6.4, 4.8, CTRL.max_climb_m_s], atol=0.05)


def test_velocity_feed_forward_removes_the_tracking_lag() -> None:
    v = np.array([4.0, 3.0, 0.0])
    start = np.array(HOVER_50M)

    def moving_target(use_ff: bool) -> Callable[[OctorotorFleet], None]:
        def set_it(fleet: OctorotorFleet) -> None:
            p = start + v * fleet.t_s
            fleet.set_target(0, position_enu_m=p, velocity_enu_m_s=v if use_ff else None)

        return set_it

    for use_ff, bound_m in ((True, 0.05), (False, None)):
        flight = _fly(_fleet(), 15.0, moving_target(use_ff))
        lag = np.linalg.norm(flight.state[:, POS_ENU] - (start + np.outer(flight.t_s, v)), axis=1)
        if bound_m is not None:
            assert lag[flight.t_s >= 8.0].max() <= bound_m
        else:
            assert lag[-1] >= 1.0  # without feed-forward the P position loop trails behind


def test_yaw_target_reached_at_limited_rate() -> None:
    fleet = _fleet()
    fleet.set_target(0, position_enu_m=HOVER_50M, yaw_rad=2.0)
    flight = _fly(fleet, 6.0)
    assert abs(flight.state[-1, IDX_PSI] - 2.0) <= 0.01
    assert np.abs(flight.state[:, IDX_R]).max() <= math.radians(CTRL.max_yaw_rate_deg_s) + 0.01
    assert np.abs(flight.state[:, IDX_R]).max() >= math.radians(CTRL.max_yaw_rate_deg_s) - 0.05


def test_yaw_turns_the_short_way_across_pi() -> None:
    fleet = _fleet(psi=3.0)
    fleet.set_target(0, position_enu_m=HOVER_50M, yaw_rad=-3.0)
    flight = _fly(fleet, 4.0)
    assert np.abs(flight.state[:, IDX_PSI]).min() >= 2.99
    assert flight.state[-1, IDX_PSI] == pytest.approx(-3.0, abs=0.01)


def test_heading_held_when_no_yaw_is_given() -> None:
    fleet = _fleet(psi=0.7)
    fleet.set_target(0, position_enu_m=(40.0, 30.0, 55.0))
    flight = _fly(fleet, 10.0)
    assert np.abs(flight.state[:, IDX_PSI] - 0.7).max() <= 0.01  # Euler coupling while tilting
    assert flight.state[-1, IDX_PSI] == pytest.approx(0.7, abs=1e-4)


def test_quantised_vehicle_holds_altitude() -> None:
    flight = _fly(_fleet(ctrl=QUANTISED), 20.0)
    assert np.abs(flight.state[:, POS_ENU] - HOVER_50M).max() <= 0.05
    assert np.isclose(flight.thrust_n[:, None], thrust_levels_n(OctorotorParams())).any(1).all()


def test_quantised_vehicle_reaches_target_within_limits() -> None:
    target = np.array([60.0, -40.0, 60.0])
    fleet = _fleet(ctrl=QUANTISED)
    fleet.set_target(0, position_enu_m=target, yaw_rad=-1.0)
    flight = _fly(fleet, 16.0)
    assert flight.settle_time_s(target, 1.0) <= 13.0
    assert np.linalg.norm(flight.state[-1, POS_ENU] - target) <= 0.1
    _assert_within_limits(flight, QUANTISED, QUANTISED_SPEED_TOL, QUANTISED_TILT_TOL_DEG)
    levels = torque_levels_nm(OctorotorParams())
    assert np.isclose(flight.torque_nm[..., None], levels).any(-1).all()


def test_disarmed_vehicle_falls_and_rests_on_the_ground() -> None:
    fleet = _fleet(start=(10.0, -5.0, 20.0))
    fleet.advance(100)
    fleet.disarm(0)
    fleet.advance(500)
    end = fleet.state_of(0)
    assert end[IDX_Z] == 0.0
    np.testing.assert_array_equal(end[VEL_ENU], 0.0)
    assert fleet.on_ground[0]
    thrust, torque = fleet.last_command
    assert thrust[0] == 0.0 and np.all(torque == 0.0)


def test_an_armed_quantised_vehicle_waiting_on_the_ground_counts_as_on_the_ground() -> None:
    """Sigma-delta thrust around m g lifts the vehicle by micrometres now and then; the land
    detector (like ArduCopter's) uses thresholds, so takeoff is not refused as "flying"."""
    fleet = _fleet(start=(0.0, 0.0, 0.0), ctrl=QUANTISED)
    moved = False
    for _ in range(200):  # 2 s of controller periods
        fleet.advance(1)
        state = fleet.state_of(0)
        moved = moved or state[IDX_Z] > 0.0 or bool(np.any(state[VEL_ENU] != 0.0))
        assert fleet.on_ground[0]
    assert moved  # the case this is about: it does not sit exactly still


def test_takeoff_after_resting_armed_without_windup() -> None:
    fleet = _fleet(start=(0.0, 0.0, 0.0))
    fleet.disarm(0)
    fleet.advance(100)
    np.testing.assert_array_equal(fleet.state_of(0), np.zeros(STATE_SIZE))
    fleet.arm(0)
    fleet.set_target(0, position_enu_m=(30.0, 0.0, -5.0))  # below ground: it cannot get there
    fleet.advance(1000)
    assert fleet.on_ground[0]
    fleet.set_target(0, position_enu_m=(0.0, 0.0, 10.0))
    flight = _fly(fleet, 12.0)
    assert flight.state[:, IDX_Z].max() <= 10.05
    assert flight.state[-1, IDX_Z] == pytest.approx(10.0, abs=0.1)
    assert np.abs(flight.state[:, IDX_X]).max() <= 0.05  # no horizontal integrator kick


def test_vehicles_in_a_fleet_fly_independently() -> None:
    targets = np.array([[50.0, 0.0, 60.0], [-20.0, 30.0, 40.0], [0.0, 0.0, 50.0]])
    starts = np.zeros((3, STATE_SIZE))
    starts[:, POS_ENU] = HOVER_50M
    fleet = OctorotorFleet(3, initial_state=starts)
    for i in range(3):
        fleet.arm(i)
        fleet.set_target(i, position_enu_m=targets[i], yaw_rad=0.5 * i)
    fleet.advance(300)
    for i in range(3):
        alone = _fleet()
        alone.set_target(0, position_enu_m=targets[i], yaw_rad=0.5 * i)
        alone.advance(300)
        np.testing.assert_array_equal(fleet.state_of(i), alone.state_of(0))


def test_advance_to_counts_whole_controller_periods() -> None:
    fleet = _fleet()
    fleet.advance_to(1.234)
    assert fleet.t_s == pytest.approx(1.23)
    fleet.advance_to(0.3 * 10)  # 3.0000000000000004 rounds to 300 periods
    assert fleet.t_s == 3.0
    with pytest.raises(ValueError, match="back in time"):
        fleet.advance_to(2.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"physics_hz": 250}, "multiple of controller_hz"),
        ({"physics_hz": 100}, "exceeds"),
        ({"max_speed_m_s": -8.0}, "max_speed_m_s"),
        ({"max_tilt_deg": 85.0}, "max_tilt_deg"),
        ({"rate_gain_rp_1_s": float("nan")}, "rate_gain_rp_1_s"),
        ({"rate_gain_yaw_1_s": 150.0}, "stable discrete rate loop"),
    ],
)
def test_controller_params_are_validated(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ControllerParams(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"thrust_min_n": 600.0}, "thrust_min_n"),
        ({"mass_kg": 60.0}, "weight"),
        ({"ixx_kg_m2": 0.0}, "ixx"),
    ],
)
def test_octorotor_params_are_validated(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        OctorotorParams(**kwargs)  # type: ignore[arg-type]
