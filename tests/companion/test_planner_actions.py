"""The action set (headings x speeds x flight-path angles + climb, descend, hover) and the
velocity-ramp rollout model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.companion.actions import (
    build_action_set,
    clip_to_envelope,
    heading_to_rad,
    rollout,
    state_at,
)
from ridsafe.companion.planner_config import PlannerConfig

CFG = PlannerConfig()
VEC = st.tuples(*(st.floats(-8.0, 8.0),) * 3)


def test_action_count_and_the_last_three() -> None:
    actions = build_action_set(CFG, 0.3)
    assert len(actions) == CFG.n_actions == 21 * 4 * 13 + 3
    np.testing.assert_allclose(actions.velocity_ned_m_s[-3], [0.0, 0.0, -CFG.max_climb_m_s])
    np.testing.assert_allclose(actions.velocity_ned_m_s[-2], [0.0, 0.0, CFG.max_descent_m_s])
    np.testing.assert_array_equal(actions.velocity_ned_m_s[-1], 0.0)
    assert actions.describe(len(actions) - 1) == "hover"
    assert actions.describe(len(actions) - 3) == "climb 2.5 m/s"


def test_the_goal_line_is_always_an_action() -> None:
    """Heading 37 deg is not one of the 16 absolute headings; the goal-relative set has it."""
    goal_heading = math.radians(37.0)
    actions = build_action_set(CFG, goal_heading)
    v = actions.velocity_ned_m_s
    straight = np.flatnonzero(
        np.isclose(np.arctan2(v[:, 1], v[:, 0]), goal_heading) & np.isclose(v[:, 2], 0.0)
    )
    np.testing.assert_allclose(sorted(actions.speed_m_s[straight]), [2.0, 4.0, 6.0, 8.0])


def test_actions_stay_in_the_envelope() -> None:
    v = build_action_set(CFG, -2.0).velocity_ned_m_s
    assert np.all(np.linalg.norm(v, axis=1) <= CFG.max_speed_m_s + 1e-12)
    assert np.all(v[:, 2] >= -CFG.max_climb_m_s) and np.all(v[:, 2] <= CFG.max_descent_m_s)


def test_turn_right_is_positive_clockwise_of_the_goal_line() -> None:
    actions = build_action_set(CFG, 0.0)  # goal due north; east is to the right
    east = np.flatnonzero(np.isclose(actions.heading_rad, math.pi / 2))
    west = np.flatnonzero(np.isclose(actions.heading_rad, 3 * math.pi / 2))
    assert np.all(actions.turn_right[east] > 0.99) and np.all(actions.turn_right[west] < -0.99)
    np.testing.assert_array_equal(actions.turn_right[-3:], 0.0)


def test_heading_to_the_goal() -> None:
    assert heading_to_rad((0.0, 0.0, -50.0), (0.0, 100.0, -50.0)) == pytest.approx(math.pi / 2)
    assert heading_to_rad((0.0, 0.0, -50.0), (-10.0, 0.0, 0.0)) == pytest.approx(math.pi)
    assert heading_to_rad((5.0, 5.0, -50.0), (5.0, 5.0, 0.0)) == 0.0  # straight above


def test_rollout_matches_the_ramp_by_hand() -> None:
    """From rest to 5 m/s north at 2.5 m/s^2: the ramp takes 2 s and covers 5 m."""
    p, v = rollout([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [1.0, 2.0, 4.0], 2.5)
    np.testing.assert_allclose(p[:, 0], [1.25, 5.0, 15.0])
    np.testing.assert_allclose(v[:, 0], [2.5, 5.0, 5.0])
    np.testing.assert_array_equal(p[:, 1:], 0.0)


def test_rollout_reversal_brakes_through_zero() -> None:
    """8 m/s north, action 8 m/s south: stops after 3.2 s and 12.8 m, then comes back."""
    p, v = rollout([0.0, 0, 0], [8.0, 0, 0], [-8.0, 0, 0], [3.2, 6.4, 10.0], 2.5)
    np.testing.assert_allclose(p[:, 0], [12.8, 0.0, -28.8], atol=1e-9)
    np.testing.assert_allclose(v[:, 0], [0.0, -8.0, -8.0], atol=1e-9)


@settings(max_examples=200)
@given(VEC, VEC, st.floats(0.5, 5.0))
def test_rollout_speed_never_exceeds_its_ends(
    v0: tuple[float, float, float], va: tuple[float, float, float], accel: float
) -> None:
    tau = np.linspace(0.0, 10.0, 41)
    p, v = rollout(np.zeros(3), v0, va, tau, accel)
    bound = max(np.linalg.norm(v0), np.linalg.norm(va)) + 1e-9
    assert np.all(np.linalg.norm(v, axis=-1) <= bound)
    dv = np.diff(v, axis=0)
    assert np.all(np.linalg.norm(dv, axis=-1) <= accel * 0.25 + 1e-9)  # |dv/dt| <= accel
    # positions integrate velocities: trapezoid rule on a fine grid (exact but for the one step
    # that holds the end of the ramp, which errs by at most accel dt^2 / 8)
    fine = np.linspace(0.0, 10.0, 10_001)
    p_fine, v_fine = rollout(np.zeros(3), v0, va, fine, accel)
    integral = np.cumsum(0.5e-3 * (v_fine[1:] + v_fine[:-1]), axis=0)
    np.testing.assert_allclose(p_fine[1:], integral, atol=accel * 1e-6)
    np.testing.assert_allclose(p, p_fine[::250], atol=1e-9)


@settings(max_examples=300)
@given(VEC, VEC, st.floats(0.0, 3.0), st.floats(0.5, 6.0))
def test_state_at_one_time_is_the_rollout_bit_for_bit(
    v0: tuple[float, float, float], va: tuple[float, float, float], tau_s: float, accel: float
) -> None:
    p0 = (12.5, -3.25, -40.0)
    p, v = state_at(p0, v0, va, tau_s, accel)
    want_p, want_v = rollout(p0, v0, va, [tau_s], accel)
    assert p == tuple(want_p[0].tolist()) and v == tuple(want_v[0].tolist())


def test_the_action_set_of_one_goal_is_not_changed_by_the_next() -> None:
    first = build_action_set(CFG, 0.3)
    kept = first.velocity_ned_m_s.copy(), first.heading_rad.copy(), first.turn_right.copy()
    build_action_set(CFG, -2.0)
    assert np.array_equal(first.velocity_ned_m_s, kept[0])
    assert np.array_equal(first.heading_rad, kept[1]) and np.array_equal(first.turn_right, kept[2])
    assert not first.speed_m_s.flags.writeable  # shared between decisions: read-only


def test_clip_to_envelope() -> None:
    np.testing.assert_allclose(clip_to_envelope([0.0, 0.0, -4.0], CFG), [0.0, 0.0, -2.5])
    np.testing.assert_allclose(clip_to_envelope([0.0, 0.0, 3.0], CFG), [0.0, 0.0, 1.5])
    clipped = clip_to_envelope([9.0, 9.0, 0.0], CFG)
    assert np.linalg.norm(clipped) == pytest.approx(8.0)
    assert clipped[0] == pytest.approx(clipped[1])
