"""The FastMDP value terms against hand-computed numbers, and the region distance against a
brute-force distance to the ellipsoid's surface."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from ridsafe.companion.value import (
    benign_reward,
    predicted_region,
    region_distance_m,
    region_intrusion_m,
    region_signed_distance_m,
    source_coefficient,
    source_value,
    state_value,
)

FloatArray = NDArray[np.float64]
CHI2_95 = 7.814727903251178

# Hand-computed (30-digit decimal arithmetic):
#   200 / (1 - 0.999^2)                 = 100050.0250125...
#   200 / (1 - 0.999^2) * 0.999^100     =  90524.4769498...
#   -500 / (1 - 0.97^2) * 0.97^50       =  -1844.8847322...
#   -(100 * 2 + 500) / (1 - 0.97^2) * 0.97^50 = -2582.8386250...
#   -1000 / (1 - 0.97^2) * 0.97^20      =  -9201.2579175...
GOAL_AT_0 = 100050.025012506
GOAL_AT_100 = 90524.4769498458
BENIGN_AT_50 = -1844.88473221157
BENIGN_T2_AT_50 = -2582.83862509620
REGION_AT_20 = -9201.25791754225


def test_goal_term_matches_hand_computation() -> None:
    assert source_coefficient(200.0, 0.999) == pytest.approx(GOAL_AT_0, rel=1e-12)
    values = source_value(200.0, 0.999, 10_000.0, [0.0, 100.0])
    np.testing.assert_allclose(values, [GOAL_AT_0, GOAL_AT_100], rtol=1e-12)


def test_benign_term_grows_with_conflict_time() -> None:
    rewards = benign_reward(-500.0, -100.0, [0.0, 2.0])
    np.testing.assert_allclose(rewards, [-500.0, -700.0])
    values = source_value(rewards, 0.97, 100.0, 50.0)
    np.testing.assert_allclose(values, [BENIGN_AT_50, BENIGN_T2_AT_50], rtol=1e-12)


def test_region_term_matches_hand_computation() -> None:
    assert source_value(-1000.0, 0.97, 150.0, 20.0) == pytest.approx(REGION_AT_20, rel=1e-12)


def test_gate_switches_a_source_off_at_its_radius() -> None:
    values = source_value(-500.0, 0.97, 100.0, [99.999, 100.0, 250.0])
    assert values[0] < 0.0
    np.testing.assert_array_equal(values[1:], [0.0, 0.0])


def test_state_value_is_best_goal_plus_worst_hazard() -> None:
    goals = np.array([[10.0, 30.0], [5.0, 1.0]])
    hazards = np.array([[-4.0, -9.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(state_value(goals, hazards), [30.0 - 9.0, 5.0])
    np.testing.assert_allclose(state_value(goals, np.zeros((2, 0))), [30.0, 5.0])


def test_region_distance_of_a_sphere_is_exact() -> None:
    sigma, c = 20.0, np.array([100.0, -50.0, -60.0])
    radius = sigma * math.sqrt(CHI2_95)  # the 95 % sphere
    directions = np.array([[1.0, 0, 0], [0, -1.0, 0], [0.6, 0.0, 0.8]])
    points = c + (radius + 33.0) * directions
    d = region_distance_m(points, c, sigma**2 * np.eye(3), CHI2_95)
    np.testing.assert_allclose(d, 33.0, rtol=1e-12)


def test_region_distance_is_zero_inside() -> None:
    cov = np.diag([400.0, 900.0, 1600.0])
    inside = np.array([[0.0, 0.0, 0.0], [40.0, 0.0, 0.0], [0.0, 0.0, 100.0]])
    np.testing.assert_array_equal(region_distance_m(inside, np.zeros(3), cov, CHI2_95), 0.0)


def test_region_signed_distance_is_the_depth_inside_a_sphere() -> None:
    sigma, c = 20.0, np.array([100.0, -50.0, -60.0])
    radius = sigma * math.sqrt(CHI2_95)
    directions = np.array([[1.0, 0, 0], [0, -1.0, 0], [0.6, 0.0, 0.8]])
    depth = np.array([5.0, 30.0, radius])  # the last point is the centre
    points = c + (radius - depth)[:, None] * directions
    signed = region_signed_distance_m(points, c, sigma**2 * np.eye(3), CHI2_95)
    np.testing.assert_allclose(signed, -depth, rtol=1e-12)


def test_region_intrusion_inside_counts_the_horizontal_depth_only() -> None:
    cov = np.diag([400.0, 900.0, 100.0])  # flat: 10 m vertical sigma
    root = math.sqrt(CHI2_95)
    centre_column = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 25.0]])  # inside, at any height
    np.testing.assert_allclose(
        region_intrusion_m(centre_column, np.zeros(3), cov, CHI2_95, 1.0), 1.0 + 10.0 * root
    )
    sideways = np.array([[20.0 * root / 2.0, 0.0, 0.0]])  # half way out along x
    np.testing.assert_allclose(
        region_intrusion_m(sideways, np.zeros(3), cov, CHI2_95, 1.0), 1.0 + 10.0 * root / 2.0
    )
    outside = np.array([[0.0, 0.0, 10.0 * root + 0.5], [0.0, 0.0, 10.0 * root + 5.0]])
    np.testing.assert_allclose(
        region_intrusion_m(outside, np.zeros(3), cov, CHI2_95, 1.0), [0.5, 0.0], atol=1e-12
    )


def _surface_points(cov: FloatArray, chi2: float, n: int = 200_000) -> FloatArray:
    """Dense sample of the ellipsoid's surface {x : x^T cov^-1 x = chi2}."""
    rng = np.random.default_rng(3)
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    lam, vec = np.linalg.eigh(cov)
    points: FloatArray = (u * np.sqrt(chi2 * lam)) @ vec.T
    return points


@settings(max_examples=25)
@given(
    st.floats(10.0, 40.0),
    st.floats(10.0, 40.0),
    st.floats(20.0, 60.0),
    st.floats(0.0, math.pi),
    st.integers(0, 2**31 - 1),
)
def test_region_distance_never_exceeds_the_euclidean_distance(
    s1: float, s2: float, s3: float, yaw: float, seed: int
) -> None:
    """Eq. (4) is a lower bound of the distance to the surface (the shield never lets a rollout
    closer than it believes) and within sigma_min / sigma_max of it."""
    rot = np.array(
        [[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]]
    )
    cov = rot @ np.diag([s1**2, s2**2, s3**2]) @ rot.T
    surface = _surface_points(cov, CHI2_95, 100_000)
    rng = np.random.default_rng(seed)
    x = rng.uniform(-300.0, 300.0, size=(20, 3))
    outside = np.einsum("ni,ij,nj->n", x, np.linalg.inv(cov), x) > CHI2_95
    x = x[outside]
    exact = np.min(np.linalg.norm(x[:, None, :] - surface[None, :, :], axis=-1), axis=1)
    bound = region_distance_m(x, np.zeros(3), cov, CHI2_95)
    assert np.all(bound <= exact + 1e-6)
    # and not a loose one: within sigma_min / sigma_max of it (the radial point is that close),
    # up to the spacing of the sampled surface (100,000 points: random gaps up to ~1.6 m on the
    # largest ellipsoids drawn; 20,000 left gaps over 3 m)
    ratio = min(s1, s2, s3) / max(s1, s2, s3)
    assert np.all(bound >= ratio * (exact - 3.0))


def test_region_distance_is_tight_along_the_smallest_axis() -> None:
    cov = np.diag([15.0**2, 30.0**2, 40.0**2])
    x = np.array([15.0 * math.sqrt(CHI2_95) + 25.0, 0.0, 0.0])
    assert region_distance_m(x, np.zeros(3), cov, CHI2_95) == pytest.approx(25.0, rel=1e-12)


def test_predicted_region_moves_and_grows() -> None:
    center, cov = predicted_region([0.0, 0.0, -60.0], [7.0, 0.0, 0.0], np.eye(3) * 400.0, 1.0, 4.0)
    np.testing.assert_allclose(center, [28.0, 0.0, -60.0])
    np.testing.assert_allclose(cov, np.eye(3) * (400.0 + 16.0))
