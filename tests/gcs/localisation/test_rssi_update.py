"""The RSSI update (iterated posterior linearisation): compiled kernels against the numpy
reference, the SLR against the analytic Jacobian, health under coplanar receivers, gating."""

from __future__ import annotations

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.localisation.config import RssiFilterConfig
from ridsafe.gcs.localisation.multilateration import rssi_jacobian
from ridsafe.gcs.localisation.rssi_update import (
    RssiMeasurement,
    _slr,
    gate_receptions,
    iplf_iterate,
    iplf_iterate_reference,
    iplf_update,
    iplf_update_reference,
    linearise,
    nearest_receivers,
)
from ridsafe.gcs.tracking.imm import Gaussian


def _meas(
    rng: np.random.Generator, p: np.ndarray, rx: np.ndarray, sigma: float = 1.0
) -> RssiMeasurement:
    d = np.linalg.norm(rx - p, axis=1)
    rssi = received_power_dbm(20.0, d) + rng.normal(0, sigma, rx.shape[0])
    return RssiMeasurement(rx, rssi, 1.0, 1.0)


def _prior(rng: np.random.Generator, batch: int, n: int, p: np.ndarray, spread: float) -> Gaussian:
    x = np.zeros((batch, n))
    x[:, :3] = p + rng.normal(0, spread, (batch, 3))
    x[:, -1] = 20.0 + rng.normal(0, 2, batch)
    A = rng.normal(size=(batch, n, n)) * 0.3
    P = A @ np.swapaxes(A, 1, 2) + np.eye(n)
    P[:, :3, :3] += np.eye(3) * spread**2
    P[:, -1, -1] += 4.0
    return Gaussian(x, P)


@pytest.mark.parametrize(("n", "k"), [(7, 12), (10, 12), (7, 3), (10, 64)])
def test_kernels_match_the_numpy_reference(n: int, k: int) -> None:
    """The kernels' rank-8 innovation algebra (Woodbury) against the dense k x k reference,
    with fewer receivers than that rank and with a 64-aircraft fleet's."""
    rng = np.random.default_rng(n + k)
    rx = np.column_stack((rng.uniform(-500, 500, (k, 2)), rng.uniform(30, 100, k)))
    p = np.array([50.0, -80.0, 60.0])
    meas = _meas(rng, p, rx)
    prior = _prior(rng, 4, n, p, 60.0)
    idx = np.array([0, 1, 2, n - 1])
    u0, Puu = prior.x[:, idx], prior.P[:, idx[:, None], idx]
    m_k, c_k = iplf_iterate(u0, Puu, meas, 6, 1e-3)
    m_r, c_r = iplf_iterate_reference(u0, Puu, meas, 6, 1e-3)
    np.testing.assert_allclose(m_k, m_r, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(c_k, c_r, rtol=1e-8, atol=1e-8)
    up_k = iplf_update(prior, n - 1, meas, linearise(meas, m_k, c_k))
    up_r = iplf_update_reference(prior, n - 1, meas, m_k, c_k)
    np.testing.assert_allclose(up_k.x, up_r.x, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(up_k.P, up_r.P, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(up_k.log_likelihood, up_r.log_likelihood, rtol=1e-9)


def test_slr_of_a_narrow_gaussian_is_the_jacobian() -> None:
    rng = np.random.default_rng(1)
    rx = np.column_stack((rng.uniform(-500, 500, (8, 2)), rng.uniform(30, 100, 8)))
    mean = np.array([[10.0, 20.0, 60.0, 20.0]])
    A, _, Omega = _slr(mean, np.eye(4)[None] * 1e-6, RssiMeasurement(rx, np.zeros(8), 1.0, 0.0))
    np.testing.assert_allclose(A[0, :, :3], rssi_jacobian(mean[0, :3], rx), rtol=1e-4)
    np.testing.assert_allclose(A[0, :, 3], 1.0, rtol=1e-9)
    assert np.abs(Omega).max() < 1e-9


def test_wide_posterior_adds_linearisation_error() -> None:
    rng = np.random.default_rng(2)
    rx = np.array([[0.0, 0.0, 60.0], [40.0, 0.0, 60.0], [0.0, 40.0, 60.0]])
    mean = np.array([[10.0, 10.0, 60.0, 20.0]])
    _, _, omega_wide = _slr(
        mean, np.diag([900.0, 900.0, 900.0, 1.0])[None], RssiMeasurement(rx, np.zeros(3), 1.0, 0.0)
    )
    assert np.all(np.linalg.eigvalsh(omega_wide[0]) > -1e-9) and np.trace(omega_wide[0]) > 1.0
    del rng


def test_update_moves_toward_the_truth_and_shrinks() -> None:
    rng = np.random.default_rng(3)
    rx = np.column_stack((rng.uniform(-500, 500, (16, 2)), rng.uniform(30, 100, 16)))
    p = np.array([100.0, 50.0, 60.0])
    prior = _prior(rng, 1, 10, p + np.array([80.0, -60.0, 0.0]), 1.0)
    prior.P[0, :2, :2] += np.eye(2) * 150.0**2
    meas = _meas(rng, p, rx, 0.3)
    idx = np.array([0, 1, 2, 9])
    m, c = iplf_iterate(prior.x[:, idx], prior.P[:, idx[:, None], idx], meas, 10, 0.01)
    up = iplf_update(prior, 9, meas, linearise(meas, m, c))
    assert np.linalg.norm(up.x[0, :2] - p[:2]) < 20.0
    assert np.trace(up.P[0, :2, :2]) < 0.05 * np.trace(prior.P[0, :2, :2])


def test_covariance_stays_positive_definite_with_coplanar_receivers() -> None:
    """Receivers in one plane with the transmitter in it: altitude is unobservable to first
    order; updates must keep P symmetric positive definite, for many transmissions."""
    rng = np.random.default_rng(4)
    rx = np.column_stack((rng.uniform(-500, 500, (10, 2)), np.full(10, 60.0)))
    p = np.array([0.0, 0.0, 60.0])
    prior = _prior(rng, 2, 10, p, 50.0)
    idx = np.array([0, 1, 2, 9])
    for _ in range(60):
        meas = _meas(rng, p, rx)
        m, c = iplf_iterate(prior.x[:, idx], prior.P[:, idx[:, None], idx], meas, 5, 0.5)
        up = iplf_update(prior, 9, meas, linearise(meas, m, c))
        prior = Gaussian(up.x, up.P + np.eye(10) * 1e-3)
        assert np.all(np.isfinite(up.log_likelihood))
    for P in prior.P:
        np.testing.assert_allclose(P, P.T, atol=1e-9)
        assert np.linalg.eigvalsh(P).min() > 0.0
    assert np.sqrt(prior.P[0, 2, 2]) > 5.0  # altitude stays honestly uncertain


def test_gate_drops_an_outlier_but_not_a_quarter_of_the_receptions() -> None:
    rng = np.random.default_rng(5)
    rx = np.column_stack((rng.uniform(-500, 500, (12, 2)), rng.uniform(30, 100, 12)))
    p = np.array([0.0, 0.0, 60.0])
    prior = _prior(rng, 1, 7, p, 1.0)
    prior.x[0, :3] = p
    prior.x[0, -1] = 20.0
    meas = _meas(rng, p, rx, 0.5)
    one = meas.rssi.copy()
    one[3] += 30.0
    keep = gate_receptions(prior, 6, RssiMeasurement(rx, one, 1.0, 1.0), 5.0, 0.25)
    assert not keep[3] and keep.sum() == 11
    many = meas.rssi.copy()
    many[:5] += 30.0
    assert gate_receptions(prior, 6, RssiMeasurement(rx, many, 1.0, 1.0), 5.0, 0.25).all()


def test_nearest_receivers_keeps_the_closest_in_their_order() -> None:
    rx = np.array([[300.0, 0, 50], [10.0, 0, 50], [200.0, 0, 50], [20.0, 0, 50], [90.0, 0, 50]])
    meas = RssiMeasurement(rx, np.arange(5.0), 1.0, 1.0)
    near = nearest_receivers(meas, np.array([0.0, 0.0, 50.0]), 3)
    assert near.rx[:, 0].tolist() == [10.0, 20.0, 90.0] and near.rssi.tolist() == [1.0, 3.0, 4.0]
    assert nearest_receivers(meas, np.zeros(3), 0) is meas  # 0: all
    assert nearest_receivers(meas, np.zeros(3), 5) is meas  # not fewer than there are


def test_max_receivers_is_checked() -> None:
    with pytest.raises(FieldValueError, match="max_receivers"):
        RssiFilterConfig(max_receivers=-1)
