"""The chance-constrained ellipsoid (paper eq. (10)-(11)): threshold, geometry, containment."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from ridsafe.common.ellipsoid import inside
from ridsafe.gcs.pipeline_config import RegionConfig
from ridsafe.gcs.region.unsafe_region import (
    chi2_threshold,
    ellipsoid_axes,
    make_region,
    positive_definite,
)


def _rotation(yaw: float, pitch: float) -> np.ndarray:
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    out: np.ndarray = Rz @ Ry
    return out


def test_threshold_is_the_chi_square_3_quantile() -> None:
    assert chi2_threshold(0.05) == pytest.approx(7.8147, abs=1e-4)  # textbook table value
    assert chi2_threshold(0.01) == pytest.approx(11.3449, abs=1e-4)
    with pytest.raises(ValueError):
        chi2_threshold(1.0)


@settings(max_examples=50)
@given(
    st.floats(-3, 3), st.floats(-1.5, 1.5), st.lists(st.floats(1.0, 1e4), min_size=3, max_size=3)
)
def test_semi_axes_and_orientation_of_a_rotated_ellipsoid(
    yaw: float, pitch: float, var: list[float]
) -> None:
    R = _rotation(yaw, pitch)
    cov = R @ np.diag(var) @ R.T
    semi, axes = ellipsoid_axes(cov, 7.8)
    np.testing.assert_allclose(semi, np.sqrt(7.8 * np.sort(var)[::-1]), rtol=1e-6)
    assert np.linalg.det(axes) == pytest.approx(1.0)
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-9)
    for k in range(3):  # the tip of each semi-axis lies on the surface
        tip = semi[k] * axes[:, k]
        assert tip @ np.linalg.solve(cov, tip) == pytest.approx(7.8, rel=1e-6)


def test_region_fields_and_validity() -> None:
    cov = np.diag([400.0, 100.0, 2500.0])
    region = make_region(
        "S",
        3,
        12.0,
        np.array([1.0, 2, 3]),
        cov,
        np.zeros(3),
        RegionConfig(alpha=0.05, validity_s=1.0),
    )
    assert region.valid_until_s == 13.0 and region.alpha == 0.05
    assert region.chi2_threshold == pytest.approx(7.8147, abs=1e-4)
    np.testing.assert_allclose(
        region.semi_axes_m, np.sqrt(7.8147 * np.array([2500.0, 400, 100])), rtol=1e-4
    )
    assert not region.center_enu_m.flags.writeable and not region.cov_enu_m2.flags.writeable


def test_containment_of_samples_is_one_minus_alpha() -> None:
    rng = np.random.default_rng(0)
    R = _rotation(0.7, 0.3)
    cov = R @ np.diag([900.0, 50.0, 4.0]) @ R.T
    region = make_region(
        "S", 1, 0.0, np.array([10.0, -5, 60]), cov, np.zeros(3), RegionConfig(alpha=0.05)
    )
    samples = rng.multivariate_normal(region.center_enu_m, cov, 4000)
    rate = float(
        np.mean(inside(samples, region.center_enu_m, region.cov_enu_m2, region.chi2_threshold))
    )
    n = samples.shape[0]
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, 0.95) / n
    assert lo <= rate <= hi


def test_positive_definite_repairs_only_what_is_broken() -> None:
    good = np.diag([1.0, 2.0, 3.0])
    assert positive_definite(good) is not good and np.array_equal(positive_definite(good), good)
    bad = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # eigenvalues -1, 1, 3
    fixed = positive_definite(bad)
    assert np.linalg.eigvalsh(fixed).min() >= 1e-6 * 0.999
    np.testing.assert_allclose(fixed, fixed.T)
