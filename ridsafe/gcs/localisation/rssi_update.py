r"""Update of a batch of mode filters on the raw RSSI of every receiver of one transmission,
by iterated posterior linearisation (IPLF; Garcia-Fernandez, Svensson, Morelande, Sarkka,
"Posterior linearization filter", IEEE TSP 2015).

The state carries the position p = x[0:3] and the transmit power Pt = x[i_pt]; together they
form the observed block u = (p, Pt). Measurement model (paper eq. (8), d in metres)::

    z_i = h_i(u) + e_i,   h_i = Pt - 10 log10(max(||p - r_i||^2, 1)) - L,
    e_i ~ N(0, R_i),      R_i = s^2 + (20/ln10)^2 sigma_rx^2 / d_i^2

(s the RSSI noise; the second term the receiver's reported-position error seen in dB).

Statistical linear regression (SLR) of h over a Gaussian N(m, C) of u, with the third-degree
cubature points u_l = m +/- sqrt(4) chol(C) e_l (l = 1..8, weights 1/8)::

    z_bar = sum w h(u_l),  Psi = sum w (u_l - m)(h(u_l) - z_bar)^T,  Phi = sum w (h - z_bar)(..)^T
    A = Psi^T C^-1,  b = z_bar - A m,  Omega = Phi - A C A^T        (h(u) ~ A u + b + N(0, Omega))

IPLF: start with (m, C) = the prior (u^-, P_uu); repeat: SLR over (m, C), then a Kalman
update of the *prior* with the linear model (A, b, R + Omega) gives the new (m, C); stop when
the position moves less than ``tol_m``. Unlike the iterated EKF, the curvature of h over the
posterior's spread enters as Omega, so a wide posterior near a receiver (or across the
receivers' plane, where altitude is ambiguous) is not made overconfident. The last SLR updates
the whole state (Joseph form)::

    S = A P_uu A^T + R + Omega,   K = P_xu A^T S^-1,   x+ = x^- + K (z - A u^- - b)
    P+ = (I - K H_x) P^- (I - K H_x)^T + K (R + Omega) K^T,   H_x = A placed at u's columns
    log Lambda = log N(z; A u^- + b, S)                        (the IMM's mode likelihood)

Every array has a leading batch axis. ``iplf_iterate``, ``linearise`` (the last SLR, once
per hypothesis for all its modes) and ``iplf_update`` run compiled kernels
(``iplf_kernels.py``); ``*_reference`` are the same equations in plain numpy, kept as the
tests' oracle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import DB_PER_LN, LOSS_AT_1M_2400MHZ_DB
from ridsafe.gcs.localisation import iplf_kernels
from ridsafe.gcs.tracking.imm import Gaussian, ModeUpdate, symmetrize

FloatArray = NDArray[np.float64]

__all__ = [
    "Linearisation",
    "RssiMeasurement",
    "gate_receptions",
    "iplf_iterate",
    "iplf_iterate_reference",
    "iplf_update",
    "iplf_update_reference",
    "linearise",
    "observed",
]

_LOG_2PI = math.log(2.0 * math.pi)
_SQRT_N = 2.0  # sqrt of the observed block's dimension (4)


@dataclass(frozen=True, eq=False)
class RssiMeasurement:
    """One transmission's receptions: ``rx : (k, 3)``, ``rssi : (k,)``."""

    rx: FloatArray
    rssi: FloatArray
    sigma_db: float
    rx_position_sigma_m: float
    loss_db: float = LOSS_AT_1M_2400MHZ_DB

    def predict(self, u: FloatArray) -> FloatArray:
        """h at points ``u : (..., 4)`` -> (..., k)."""
        diff = u[..., None, :3] - self.rx
        d2 = np.maximum(np.sum(diff * diff, axis=-1), 1.0)
        out: FloatArray = u[..., 3:4] - 10.0 * np.log10(d2) - self.loss_db
        return out

    def variance(self, u: FloatArray) -> FloatArray:
        """R_i at ``u : (B, 4)`` -> (B, k)."""
        d2 = np.maximum(np.sum((u[:, None, :3] - self.rx) ** 2, axis=-1), 1.0)
        out: FloatArray = self.sigma_db**2 + (DB_PER_LN * self.rx_position_sigma_m) ** 2 / d2
        return out

    @property
    def rx_variance_db2_m2(self) -> float:
        """(20/ln10 sigma_rx)^2: the receiver-position term of R_i is this over d_i^2."""
        return float((DB_PER_LN * self.rx_position_sigma_m) ** 2)

    def subset(self, keep: NDArray[np.bool_]) -> RssiMeasurement:
        return RssiMeasurement(
            self.rx[keep], self.rssi[keep], self.sigma_db, self.rx_position_sigma_m, self.loss_db
        )


def nearest_receivers(meas: RssiMeasurement, p_enu_m: FloatArray, limit: int) -> RssiMeasurement:
    """``meas`` with only its ``limit`` receptions nearest ``p_enu_m`` (3,), in their order
    (all of it when ``limit`` is 0 or not below their number)."""
    k = meas.rx.shape[0]
    if limit <= 0 or k <= limit:
        return meas
    d2 = np.sum((meas.rx - p_enu_m) ** 2, axis=1)
    keep = np.zeros(k, dtype=bool)
    keep[np.argpartition(d2, limit - 1)[:limit]] = True
    return meas.subset(keep)


def observed(i_pt: int) -> NDArray[np.int64]:
    """Indices of the observed block (p, Pt) in a state whose power is at ``i_pt``."""
    return np.array([0, 1, 2, i_pt])


def gate_receptions(
    prior: Gaussian, i_pt: int, meas: RssiMeasurement, gate_sigma: float, max_fraction: float
) -> NDArray[np.bool_]:
    """Receptions to keep: innovation at the (single) prior within ``gate_sigma`` standard
    deviations, S_ii = (A P_uu A^T + Omega)_ii + R_i from the SLR over the prior. When more
    than ``max_fraction`` would go, the estimate is the suspect, not the receptions: keep
    them all."""
    keep: NDArray[np.bool_] = iplf_kernels.gate(
        np.ascontiguousarray(prior.x[0]),
        np.ascontiguousarray(prior.P[0]),
        i_pt,
        np.ascontiguousarray(meas.rx),
        np.ascontiguousarray(meas.rssi),
        meas.sigma_db**2,
        meas.rx_variance_db2_m2,
        meas.loss_db,
        gate_sigma,
    )
    if np.count_nonzero(~keep) > max_fraction * keep.shape[0]:
        return np.ones_like(keep)
    return keep


def _slr(
    mean: FloatArray, cov: FloatArray, meas: RssiMeasurement
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """SLR of h over N(mean (B, 4), cov (B, 4, 4)): A (B, k, 4), b (B, k), Omega (B, k, k)."""
    L = np.linalg.cholesky(cov) * _SQRT_N  # (B, 4, 4), columns are the offsets
    offsets = np.concatenate((np.swapaxes(L, -1, -2), -np.swapaxes(L, -1, -2)), axis=1)
    points = mean[:, None, :] + offsets  # (B, 8, 4)
    Z = meas.predict(points)  # (B, 8, k)
    z_bar = Z.mean(axis=1)
    dZ = Z - z_bar[:, None, :]
    w = 1.0 / offsets.shape[1]
    Psi = w * np.swapaxes(offsets, -1, -2) @ dZ  # (B, 4, k)
    Phi = w * np.swapaxes(dZ, -1, -2) @ dZ  # (B, k, k)
    A = np.swapaxes(np.linalg.solve(cov, Psi), -1, -2)  # (B, k, 4)
    b = z_bar - (A @ mean[..., None])[..., 0]
    Omega = symmetrize(Phi - A @ cov @ np.swapaxes(A, -1, -2))
    return A, b, Omega


def _linear_update(
    u0: FloatArray, Puu: FloatArray, A: FloatArray, b: FloatArray, Rt: FloatArray, z: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Kalman update of N(u0, Puu) with z = A u + b + N(0, Rt): (mean, cov, S, nu)."""
    APuu = A @ Puu  # (B, k, 4)
    S = symmetrize(APuu @ np.swapaxes(A, -1, -2) + Rt)
    K = np.swapaxes(np.linalg.solve(S, APuu), -1, -2)  # (B, 4, k)
    nu = z - (A @ u0[..., None])[..., 0] - b
    mean = u0 + (K @ nu[..., None])[..., 0]
    cov = symmetrize(Puu - K @ S @ np.swapaxes(K, -1, -2))
    return mean, cov, S, nu


def iplf_iterate(
    u0: FloatArray, Puu: FloatArray, meas: RssiMeasurement, max_iter: int, tol_m: float
) -> tuple[FloatArray, FloatArray]:
    """The IPLF iterations on the observed block only: the posterior (mean, cov) (B, 4)."""
    return iplf_kernels.iplf_iterate_batch(
        np.ascontiguousarray(u0),
        np.ascontiguousarray(Puu),
        np.ascontiguousarray(meas.rx),
        np.ascontiguousarray(meas.rssi),
        meas.sigma_db**2,
        meas.rx_variance_db2_m2,
        meas.loss_db,
        max_iter,
        tol_m,
    )


@dataclass(frozen=True, eq=False)
class Linearisation:
    """The SLR of h over each batch item's observed-block posterior:
    h(u) ~ A u + b + N(0, Omega); ``A`` (B, k, 4), ``b`` (B, k), R's diagonal ``r_db2``
    (B, k) and ``E`` (B, 4, k) with Omega = E^T E (rank 4: ``iplf_kernels.py``).
    Computed once per hypothesis and used by every one of its modes."""

    A: FloatArray
    b: FloatArray
    r_db2: FloatArray
    E: FloatArray


def linearise(meas: RssiMeasurement, post_mean: FloatArray, post_cov: FloatArray) -> Linearisation:
    """The linearisation of the final update over the posterior (``post_mean``, ``post_cov``
    from :func:`iplf_iterate`)."""
    A, b, r_db2, E = iplf_kernels.linearise_batch(
        np.ascontiguousarray(post_mean),
        np.ascontiguousarray(post_cov),
        np.ascontiguousarray(meas.rx),
        meas.sigma_db**2,
        meas.rx_variance_db2_m2,
        meas.loss_db,
    )
    return Linearisation(A, b, r_db2, E)


def iplf_update(
    prior: Gaussian, i_pt: int, meas: RssiMeasurement, lin: Linearisation
) -> ModeUpdate:
    """The whole-state update of ``prior`` (batch) with the linearisation over the observed
    block's posterior (:func:`linearise`)."""
    x, P, loglik = iplf_kernels.iplf_final(
        np.ascontiguousarray(prior.x),
        np.ascontiguousarray(prior.P),
        i_pt,
        lin.A,
        lin.b,
        lin.r_db2,
        lin.E,
        np.ascontiguousarray(meas.rssi),
    )
    return ModeUpdate(x, P, loglik)


def iplf_iterate_reference(
    u0: FloatArray, Puu: FloatArray, meas: RssiMeasurement, max_iter: int, tol_m: float
) -> tuple[FloatArray, FloatArray]:
    """Numpy reference of :func:`iplf_iterate`."""
    mean, cov = u0, Puu
    for _ in range(max_iter):
        A, b, Omega = _slr(mean, cov, meas)
        Rt = Omega + _diag(meas.variance(mean))
        new_mean, new_cov, _, _ = _linear_update(u0, Puu, A, b, Rt, meas.rssi)
        step = float(np.max(np.linalg.norm(new_mean[:, :3] - mean[:, :3], axis=1)))
        mean, cov = new_mean, new_cov
        if step < tol_m:
            break
    return mean, cov


def _diag(v: FloatArray) -> FloatArray:
    out = np.zeros((*v.shape, v.shape[-1]))
    idx = np.arange(v.shape[-1])
    out[..., idx, idx] = v
    return out


def iplf_update_reference(
    prior: Gaussian, i_pt: int, meas: RssiMeasurement, post_mean: FloatArray, post_cov: FloatArray
) -> ModeUpdate:
    """Numpy reference of :func:`iplf_update`."""
    idx = observed(i_pt)
    x0, P0 = prior.x, prior.P
    u0 = x0[:, idx]
    Puu = P0[:, idx[:, None], idx]
    A, b, Omega = _slr(post_mean, post_cov, meas)
    Rt = Omega + _diag(meas.variance(post_mean))
    APux = A @ P0[:, idx, :]  # (B, k, n)
    S = symmetrize(A @ Puu @ np.swapaxes(A, -1, -2) + Rt)
    L = np.linalg.cholesky(S)
    K = np.swapaxes(np.linalg.solve(S, APux), -1, -2)  # (B, n, k)
    nu = meas.rssi - (A @ u0[..., None])[..., 0] - b
    n = x0.shape[1]
    IKH = np.broadcast_to(np.eye(n), P0.shape).copy()
    IKH[:, :, idx] -= K @ A
    P = IKH @ P0 @ np.swapaxes(IKH, -1, -2) + K @ Rt @ np.swapaxes(K, -1, -2)
    white = np.linalg.solve(L, nu[..., None])[..., 0]
    log_det = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    loglik = -0.5 * (np.sum(white * white, axis=-1) + log_det + nu.shape[-1] * _LOG_2PI)
    return ModeUpdate(x0 + (K @ nu[..., None])[..., 0], symmetrize(P), loglik)
