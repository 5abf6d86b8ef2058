"""Saturation, disarming, and sigma-delta quantisation to the paper's action set."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from ridsafe.sim_backend.actuation import (
    N_COMMAND,
    actuate_into,
    quantise_nearest,
    quantise_sigma_delta,
    saturate,
    thrust_levels_n,
    torque_levels_nm,
)
from ridsafe.sim_backend.dynamics import OctorotorConsts
from ridsafe.sim_backend.params import OctorotorParams

FloatArray = NDArray[np.float64]

PAPER = OctorotorParams()
KO = OctorotorConsts.from_params(PAPER)
THRUST_LEVELS = thrust_levels_n(PAPER)
TORQUE_LEVELS = torque_levels_nm(PAPER)


def _actuate(
    wished: list[float], *, armed: bool, quantise: bool, error: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    cmd = np.array(wished, dtype=np.float64)
    sd_error = np.zeros(N_COMMAND) if error is None else error
    actuate_into(cmd, armed, quantise, sd_error, THRUST_LEVELS, TORQUE_LEVELS, KO)
    return cmd, sd_error


def test_action_set_is_the_papers() -> None:
    assert THRUST_LEVELS.shape == (9,)
    assert THRUST_LEVELS[0] == pytest.approx(50.0) and THRUST_LEVELS[-1] == pytest.approx(500.0)
    np.testing.assert_allclose(THRUST_LEVELS[1:] / THRUST_LEVELS[:-1], 10.0 ** (1.0 / 8.0))
    np.testing.assert_allclose(TORQUE_LEVELS, [-150, -100, -50, 0, 50, 100, 150], atol=1e-12)


def test_saturation_clips_thrust_and_each_torque_axis() -> None:
    thrust, torque = saturate(
        np.array([10.0, 300.0, 900.0]), np.array([[-200.0, 5.0, 151.0]] * 3), PAPER
    )
    np.testing.assert_array_equal(thrust, [50.0, 300.0, 500.0])
    np.testing.assert_array_equal(torque[0], [-150.0, 5.0, 150.0])
    cmd, _ = _actuate([10.0, -200.0, 5.0, 151.0], armed=True, quantise=False)
    np.testing.assert_array_equal(cmd, [50.0, -150.0, 5.0, 150.0])


def test_disarmed_means_motors_stopped_below_the_idle_minimum() -> None:
    cmd, error = _actuate(
        [300.0, 20.0, -20.0, 5.0], armed=False, quantise=True, error=np.array([9.0, 1.0, 2.0, 3.0])
    )
    np.testing.assert_array_equal(cmd, 0.0)
    np.testing.assert_array_equal(error, 0.0)


def test_nearest_level_alone_cannot_hover() -> None:
    """m g = 124.2 N lies between two levels: nearest quantisation is off by > 5 N forever."""
    hover = PAPER.weight_n
    assert abs(quantise_nearest(np.array([hover]), THRUST_LEVELS)[0] - hover) > 5.0


def test_sigma_delta_average_matches_hover_thrust() -> None:
    hover, error, applied = PAPER.weight_n, 0.0, []
    for _ in range(1000):
        value, error = quantise_sigma_delta(hover, error, THRUST_LEVELS)
        applied.append(value)
    assert set(applied) <= set(THRUST_LEVELS)
    # The mean misses by at most the carried error / n, the carried error by half a gap.
    max_gap = float(np.diff(THRUST_LEVELS).max())
    assert abs(np.mean(applied) - hover) <= 0.5 * max_gap / 1000
    assert abs(np.mean(applied[:10]) - hover) <= 0.5 * max_gap / 10


def test_quantised_armed_command_uses_only_action_set_values() -> None:
    error = np.zeros(N_COMMAND)
    for wished in ([124.0, 12.0, -70.0, 0.0], [700.0, 400.0, -400.0, 1.0]):
        cmd, error = _actuate(wished, armed=True, quantise=True, error=error)
        assert np.isclose(THRUST_LEVELS, cmd[0]).any()
        assert all(np.isclose(TORQUE_LEVELS, c).any() for c in cmd[1:])


@settings(max_examples=60)
@given(
    st.lists(st.floats(50.0, 500.0, allow_nan=False), min_size=1, max_size=200),
    st.sampled_from(["thrust", "torque"]),
)
def test_sigma_delta_running_sum_tracks_the_wish(values: list[float], channel: str) -> None:
    """Property: every output is a level and sum(applied) - sum(wished) stays within half a gap."""
    levels = THRUST_LEVELS if channel == "thrust" else TORQUE_LEVELS
    wished = np.array(values) if channel == "thrust" else (np.array(values) - 275.0) * (150 / 225)
    bound = 0.5 * float(np.diff(levels).max()) + 1e-9
    error, drift = 0.0, 0.0
    for v in wished:
        applied, error = quantise_sigma_delta(float(v), error, levels)
        assert np.isclose(levels, applied, rtol=0, atol=1e-12).any()
        drift += applied - v
        assert abs(drift) <= bound


def test_quantise_nearest_handles_out_of_range_and_ties() -> None:
    levels = np.array([-1.0, 0.0, 1.0])
    np.testing.assert_array_equal(
        quantise_nearest(np.array([-5.0, -0.5, 0.2, 0.5, 0.51, 7.0]), levels),
        [-1.0, -1.0, 0.0, 0.0, 1.0, 1.0],
    )
