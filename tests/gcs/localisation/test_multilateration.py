"""Multilateration: exact recovery without noise (property test over random non-degenerate
geometries, every solver), the Gauss-Newton covariance re-derived from a finite-difference
Jacobian, its Monte-Carlo consistency, and rejections with a reason."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import stats

from ridsafe.gcs.localisation.config import MultilaterationConfig
from ridsafe.gcs.localisation.multilateration import (
    FixStatus,
    predicted_rssi,
    rssi_jacobian,
    solve_joint,
    solve_position_only,
)

LOSS = 40.0442
METHODS = ("trf", "lm")


def paper_rssi(pt: float, p: np.ndarray, rx: np.ndarray) -> np.ndarray:
    """Paper eq. (8) as printed: Pt - 20 log10(d_km) - 20 log10(2400) - 32.44."""
    d_km = np.linalg.norm(rx - p, axis=1) / 1000.0
    out: np.ndarray = pt - 20.0 * np.log10(d_km) - 20.0 * math.log10(2400.0) - 32.44
    return out


@st.composite
def geometries(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, float]:
    """Receivers spread in 3D around a transmitter inside their hull (non-degenerate)."""
    seed = draw(st.integers(0, 2**32 - 1))
    k = draw(st.integers(8, 16))
    rng = np.random.default_rng(seed)
    p = np.array([*rng.uniform(-150, 150, 2), rng.uniform(40, 120)])
    rx = np.column_stack((rng.uniform(-400, 400, (k, 2)), rng.uniform(0, 250, k)))
    J = np.column_stack((rssi_jacobian(p, rx), np.ones(k)))
    # Non-degenerate: 1 dB of noise would leave the position within 40 m (1 sigma).
    assume(np.max(np.linalg.eigvalsh(np.linalg.inv(J.T @ J)[:3, :3])) < 40.0**2)
    return rx, p, float(rng.uniform(0.0, 30.0))


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=40)
@given(geo=geometries())
def test_exact_recovery_without_noise(
    method: str, geo: tuple[np.ndarray, np.ndarray, float]
) -> None:
    rx, p, pt = geo
    cfg = MultilaterationConfig(method=method, max_nfev=200)  # type: ignore[arg-type]
    # A warm start (the track's estimate): from far away the non-convex cost can hold a
    # local minimum inside the 1 dB noise ellipse (one seed: 0.2 dB RMS, 43 m off), which
    # no solver can tell from the truth.
    start = np.r_[p + np.array([8.0, -6.0, 4.0]), pt + 1.0]
    fix = solve_joint(rx, paper_rssi(pt, p, rx), start, 1.0, cfg)
    assert fix.ok, fix.reason
    np.testing.assert_allclose(fix.p_enu_m, p, atol=1e-3)
    assert fix.tx_power_dbm == pytest.approx(pt, abs=1e-4)
    assert fix.rms_residual_db < 1e-6


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=25)
@given(geo=geometries())
def test_position_only_recovery_at_the_known_power(
    method: str, geo: tuple[np.ndarray, np.ndarray, float]
) -> None:
    rx, p, pt = geo
    cfg = MultilaterationConfig(method=method, max_nfev=200)  # type: ignore[arg-type]
    fix = solve_position_only(rx, paper_rssi(pt, p, rx), p + 10.0, pt, 0.0, 1.0, cfg)
    assert fix.ok and fix.position_only
    np.testing.assert_allclose(fix.p_enu_m, p, atol=1e-3)


def test_model_and_jacobian_against_the_paper_and_finite_differences() -> None:
    rng = np.random.default_rng(1)
    rx = rng.uniform(-400, 400, (7, 3))
    p = np.array([10.0, -20.0, 60.0])
    np.testing.assert_allclose(
        predicted_rssi(p, 17.0, rx, LOSS), paper_rssi(17.0, p, rx), atol=1e-3
    )
    eps = 1e-4
    fd = np.column_stack(
        [
            (
                predicted_rssi(p + eps * e, 0.0, rx, LOSS)
                - predicted_rssi(p - eps * e, 0.0, rx, LOSS)
            )
            / (2 * eps)
            for e in np.eye(3)
        ]
    )
    np.testing.assert_allclose(rssi_jacobian(p, rx), fd, rtol=1e-6, atol=1e-9)


def test_covariance_is_gauss_newton_at_the_solution() -> None:
    rng = np.random.default_rng(2)
    rx = np.column_stack((rng.uniform(-500, 500, (10, 2)), rng.uniform(20, 140, 10)))
    p, pt, sigma = np.array([50.0, 80.0, 60.0]), 20.0, 1.5
    fix = solve_joint(rx, paper_rssi(pt, p, rx), np.r_[p, pt], sigma, MultilaterationConfig())
    J = np.column_stack((rssi_jacobian(fix.p_enu_m, rx), np.ones(10)))
    C = sigma**2 * np.linalg.inv(J.T @ J)
    np.testing.assert_allclose(fix.cov_enu_m2, C[:3, :3], rtol=1e-6)
    assert fix.tx_power_var_db2 == pytest.approx(C[3, 3], rel=1e-6)


def test_position_only_covariance_carries_the_power_uncertainty() -> None:
    rng = np.random.default_rng(4)
    rx = np.column_stack((rng.uniform(-500, 500, (8, 2)), rng.uniform(20, 140, 8)))
    p = np.array([0.0, 0.0, 60.0])
    z = paper_rssi(20.0, p, rx)
    cfg = MultilaterationConfig()
    exact = solve_position_only(rx, z, p, 20.0, 0.0, 1.0, cfg)
    vague = solve_position_only(rx, z, p, 20.0, 4.0, 1.0, cfg)
    J = rssi_jacobian(p, rx)
    sens = -np.linalg.solve(J.T @ J, J.T @ np.ones(8))
    np.testing.assert_allclose(
        vague.cov_enu_m2 - exact.cov_enu_m2, 4.0 * np.outer(sens, sens), rtol=1e-6
    )


def test_fix_covariance_is_consistent_in_a_well_conditioned_geometry() -> None:
    """Seeded Monte-Carlo: 16 receivers spread in 3D, 1 dB noise: the NEES of the fixes
    averages to 3 within its chi-square 99.9 % bounds."""
    rng = np.random.default_rng(7)
    rx = np.column_stack((rng.uniform(-300, 300, (16, 2)), rng.uniform(0, 200, 16)))
    p, pt = np.array([20.0, -40.0, 90.0]), 20.0
    cfg = MultilaterationConfig(method="lm")
    nees = []
    for _ in range(300):
        z = paper_rssi(pt, p, rx) + rng.normal(0, 1.0, 16)
        fix = solve_joint(rx, z, np.r_[p, pt], 1.0, cfg)
        assert fix.ok
        e = fix.p_enu_m - p
        nees.append(e @ np.linalg.solve(fix.cov_enu_m2, e))
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 3 * len(nees)) / len(nees)
    assert lo < np.mean(nees) < hi


def test_rejections_name_their_reason() -> None:
    cfg = MultilaterationConfig()
    rx = np.array([[0.0, 0.0, 50.0], [100.0, 0.0, 50.0], [0.0, 100.0, 50.0]])
    assert solve_joint(rx, np.zeros(3), None, 1.0, cfg).status is FixStatus.TOO_FEW_RECEIVERS
    same = np.repeat(np.array([[0.0, 0.0, 50.0]]), 6, axis=0)  # one place, six receivers
    fix = solve_joint(same, np.full(6, -60.0), None, 1.0, cfg)
    assert fix.status in (
        FixStatus.ILL_CONDITIONED,
        FixStatus.TOO_UNCERTAIN,
        FixStatus.NOT_CONVERGED,
    )
    assert fix.reason and not fix.ok and np.all(np.isnan(fix.p_enu_m))
    tight = MultilaterationConfig(max_nfev=1, method="trf")
    rng = np.random.default_rng(0)
    rx6 = rng.uniform(-400, 400, (6, 3))
    far = solve_joint(rx6, paper_rssi(20.0, np.array([300.0, 0, 50]), rx6), None, 1.0, tight)
    assert far.status is FixStatus.NOT_CONVERGED


def test_config_validation_names_the_field() -> None:
    with pytest.raises(ValueError, match="min_receivers"):
        MultilaterationConfig(min_receivers=3)
    with pytest.raises(ValueError, match="tx_power_bounds_dbm"):
        MultilaterationConfig(tx_power_bounds_dbm=(10.0, -10.0))
