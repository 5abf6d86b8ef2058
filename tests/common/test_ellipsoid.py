"""The containment reference: against an independent computation (explicit inverse), on the
boundary, with singular covariances, broadcast, and at its nominal rate on samples."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy import stats

from ridsafe.common.ellipsoid import inside, mahalanobis2

CHI2_95 = float(stats.chi2.ppf(0.95, 3))


def _rotation(a: float, b: float) -> NDArray[np.float64]:
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    rz = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cb, -sb], [0.0, sb, cb]])
    out: NDArray[np.float64] = rz @ rx
    return out


@settings(max_examples=60)
@given(
    st.lists(st.floats(0.5, 2000.0), min_size=3, max_size=3),
    st.floats(-3.0, 3.0),
    st.floats(-3.0, 3.0),
    st.lists(st.floats(-300.0, 300.0), min_size=3, max_size=3),
)
def test_matches_the_explicit_inverse(
    variances: list[float], a: float, b: float, offset: list[float]
) -> None:
    R = _rotation(a, b)
    cov = R @ np.diag(variances) @ R.T
    cov = 0.5 * (cov + cov.T)
    d = np.asarray(offset)
    expected = float(d @ np.linalg.inv(cov) @ d)
    assert float(mahalanobis2(d, cov)) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_boundary_and_axes_of_an_axis_aligned_ellipsoid() -> None:
    cov = np.diag([400.0, 100.0, 25.0])  # std 20, 10, 5 m
    center = np.array([10.0, -5.0, 60.0])
    r = np.sqrt(CHI2_95)
    on_axes = center + np.array([[20.0 * r, 0, 0], [0, 10.0 * r, 0], [0, 0, 5.0 * r]])
    np.testing.assert_allclose(mahalanobis2(on_axes - center, cov), CHI2_95, rtol=1e-12)
    assert inside(center + 0.999 * (on_axes - center), center, cov, CHI2_95).all()
    assert not inside(center + 1.001 * (on_axes - center), center, cov, CHI2_95).any()
    # 5 m off along the narrow (up) axis is farther than 19 m along the wide (east) axis
    assert mahalanobis2([0.0, 0.0, 5.0], cov) > mahalanobis2([19.0, 0.0, 0.0], cov)


def test_singular_covariance_is_finite_on_its_support_and_inf_off_it() -> None:
    flat = np.diag([100.0, 100.0, 0.0])  # no vertical extent
    assert float(mahalanobis2([10.0, 0.0, 0.0], flat)) == pytest.approx(1.0)
    assert float(mahalanobis2([0.0, 0.0, 1.0], flat)) == np.inf
    assert float(mahalanobis2([0.0, 0.0, 0.0], np.zeros((3, 3)))) == 0.0


def test_broadcasts_points_against_regions() -> None:
    centers = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]])  # (R, 3)
    covs = np.stack((np.eye(3) * 100.0, np.eye(3) * 4.0))  # (R, 3, 3)
    points = np.array([[5.0, 0.0, 0.0], [101.0, 0.0, 0.0], [50.0, 0.0, 0.0]])  # (N, 3)
    m2 = mahalanobis2(points[:, None, :] - centers, covs)  # (N, R)
    assert m2.shape == (3, 2)
    np.testing.assert_allclose(m2[:, 0], [0.25, 102.01, 25.0])
    np.testing.assert_allclose(m2[:, 1], [9025.0 / 4.0, 0.25, 625.0])
    got = inside(points[:, None, :], centers, covs, np.array([CHI2_95, CHI2_95]))
    np.testing.assert_array_equal(got, [[True, False], [False, True], [False, False]])


def test_nan_point_is_never_inside() -> None:
    assert not inside([np.nan, 0.0, 0.0], np.zeros(3), np.eye(3), CHI2_95)


def test_samples_are_inside_at_the_nominal_rate() -> None:
    rng = np.random.default_rng(5)
    R = _rotation(0.4, -1.1)
    cov = R @ np.diag([900.0, 60.0, 3.0]) @ R.T
    center = np.array([-40.0, 12.0, 55.0])
    samples = rng.multivariate_normal(center, cov, 5000)
    rate = float(np.mean(inside(samples, center, cov, CHI2_95)))
    lo, hi = stats.binom.ppf([0.0005, 0.9995], samples.shape[0], 0.95) / samples.shape[0]
    assert lo <= rate <= hi
