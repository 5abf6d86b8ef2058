r"""Compiled (numba) kernels of the iterated posterior linearisation in ``rssi_update.py``.

The same equations as the numpy reference there (which the tests compare against), looped
per batch item so a 16-receiver update costs microseconds instead of numpy's per-call
overhead:

    SLR over N(m, C) with cubature points m +/- 2 chol(C) e_l:   A = Psi^T C^-1,
    b = z_bar - A m,  Omega = Phi - A C A^T;
    update of N(u0, Puu) by z = A u + b + N(0, R + Omega):       S = A Puu A^T + R + Omega,
    K = Puu A^T S^-1,  m+ = u0 + K (z - A u0 - b),  C+ = Puu - K A Puu.

The on-disk cache does not notice edits in other modules a kernel calls: after editing,
delete ``ridsafe/gcs/__pycache__/*.nb[ci]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
_F = TypeVar("_F", bound=Callable[..., Any])

__all__ = ["gate", "iplf_final", "iplf_iterate_batch"]

_LOG_2PI = math.log(2.0 * math.pi)


def _jit(fn: _F) -> _F:
    return cast(_F, njit(cache=True)(fn))


@_jit
def _distances2(p: FloatArray, rx: FloatArray) -> FloatArray:
    k = rx.shape[0]
    out = np.empty(k)
    for i in range(k):
        d2 = (p[0] - rx[i, 0]) ** 2 + (p[1] - rx[i, 1]) ** 2 + (p[2] - rx[i, 2]) ** 2
        out[i] = max(d2, 1.0)
    return out


@_jit
def _slr(mean: FloatArray, cov: FloatArray, rx: FloatArray, loss: float) -> tuple[Any, Any, Any]:
    k = rx.shape[0]
    L = np.linalg.cholesky(cov) * 2.0
    pts = np.empty((8, 4))
    for col in range(4):
        for r in range(4):
            pts[col, r] = mean[r] + L[r, col]
            pts[col + 4, r] = mean[r] - L[r, col]
    Z = np.empty((8, k))
    for m in range(8):
        d2 = _distances2(pts[m], rx)
        for i in range(k):
            Z[m, i] = pts[m, 3] - 10.0 * math.log10(d2[i]) - loss
    z_bar = np.zeros(k)
    for m in range(8):
        z_bar += Z[m]
    z_bar /= 8.0
    dU = pts - mean
    dZ = Z - z_bar
    Psi = dU.T @ dZ / 8.0  # (4, k)
    Phi = dZ.T @ dZ / 8.0  # (k, k)
    A = np.linalg.solve(cov, Psi).T.copy()  # (k, 4)
    b = z_bar - A @ mean
    Omega = Phi - A @ cov @ A.T
    Omega = 0.5 * (Omega + Omega.T)
    return A, b, Omega


@_jit
def _update(
    u0: FloatArray,
    Puu: FloatArray,
    A: FloatArray,
    b: FloatArray,
    Rt: FloatArray,
    z: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    APuu = A @ Puu  # (k, 4)
    S = APuu @ A.T + Rt
    S = 0.5 * (S + S.T)
    K = np.linalg.solve(S, APuu).T.copy()  # (4, k)
    nu = z - A @ u0 - b
    mean = u0 + K @ nu
    cov = Puu - K @ APuu
    return mean, 0.5 * (cov + cov.T)


@_jit
def _with_r(
    Omega: FloatArray, mean: FloatArray, rx: FloatArray, s2: float, rx2: float
) -> FloatArray:
    d2 = _distances2(mean, rx)
    Rt = Omega.copy()
    for i in range(rx.shape[0]):
        Rt[i, i] += s2 + rx2 / d2[i]
    return Rt


@_jit
def iplf_iterate_batch(
    u0: FloatArray,
    Puu: FloatArray,
    rx: FloatArray,
    z: FloatArray,
    s2: float,
    rx2: float,
    loss: float,
    max_iter: int,
    tol_m: float,
) -> tuple[FloatArray, FloatArray]:
    """Posterior (mean (B, 4), cov (B, 4, 4)) of each batch item's observed block.

    ``s2`` the RSSI variance, ``rx2`` = ((20/ln10) sigma_rx)^2 (dB^2 m^2)."""
    B = u0.shape[0]
    mean = u0.copy()
    cov = Puu.copy()
    for h in range(B):
        m = u0[h].copy()
        c = Puu[h].copy()
        for _ in range(max_iter):
            A, b, Omega = _slr(m, c, rx, loss)
            Rt = _with_r(Omega, m, rx, s2, rx2)
            m_new, c_new = _update(u0[h], Puu[h], A, b, Rt, z)
            step = math.sqrt(np.sum((m_new[:3] - m[:3]) ** 2))
            m, c = m_new, c_new
            if step < tol_m:
                break
        mean[h] = m
        cov[h] = c
    return mean, cov


@_jit
def iplf_final(
    x0: FloatArray,
    P0: FloatArray,
    i_pt: int,
    post_mean: FloatArray,
    post_cov: FloatArray,
    rx: FloatArray,
    z: FloatArray,
    s2: float,
    rx2: float,
    loss: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Whole-state update of each batch item, linearised over its observed block's
    posterior; Joseph form; (x (B, n), P (B, n, n), log-likelihood (B,))."""
    B, n = x0.shape
    k = rx.shape[0]
    idx = np.array([0, 1, 2, i_pt])
    x_out = np.empty_like(x0)
    P_out = np.empty_like(P0)
    loglik = np.empty(B)
    for h in range(B):
        A, b, Omega = _slr(post_mean[h], post_cov[h], rx, loss)
        Rt = _with_r(Omega, post_mean[h], rx, s2, rx2)
        Pux = np.empty((4, n))
        u0 = np.empty(4)
        for r in range(4):
            Pux[r] = P0[h, idx[r]]
            u0[r] = x0[h, idx[r]]
        Puu = np.empty((4, 4))
        for r in range(4):
            for c in range(4):
                Puu[r, c] = Pux[r, idx[c]]
        APux = A @ Pux  # (k, n)
        S = A @ Puu @ A.T + Rt
        S = 0.5 * (S + S.T)
        L = np.linalg.cholesky(S)
        K = np.linalg.solve(S, APux).T.copy()  # (n, k)
        nu = z - A @ u0 - b
        x_out[h] = x0[h] + K @ nu
        KA = K @ A  # (n, 4)
        IKH = np.eye(n)
        for r in range(4):
            IKH[:, idx[r]] -= KA[:, r]
        P = IKH @ P0[h] @ IKH.T + K @ Rt @ K.T
        P_out[h] = 0.5 * (P + P.T)
        white = np.empty(k)  # L^-1 nu by forward substitution
        log_det = 0.0
        for i in range(k):
            acc = nu[i]
            for j in range(i):
                acc -= L[i, j] * white[j]
            white[i] = acc / L[i, i]
            log_det += 2.0 * math.log(L[i, i])
        loglik[h] = -0.5 * (np.sum(white * white) + log_det + k * _LOG_2PI)
    return x_out, P_out, loglik


@_jit
def gate(
    mean: FloatArray,
    cov: FloatArray,
    rx: FloatArray,
    z: FloatArray,
    s2: float,
    rx2: float,
    loss: float,
    gate_sigma: float,
) -> NDArray[np.bool_]:
    """|z_i - (A m + b)_i| <= gate_sigma sqrt(S_ii), S_ii = (A C A^T + Omega)_ii + R_i."""
    A, b, Omega = _slr(mean, cov, rx, loss)
    Rt = _with_r(Omega, mean, rx, s2, rx2)
    h = A @ mean + b
    ACA = A @ cov @ A.T
    keep = np.empty(rx.shape[0], dtype=np.bool_)
    for i in range(rx.shape[0]):
        keep[i] = abs(z[i] - h[i]) <= gate_sigma * math.sqrt(ACA[i, i] + Rt[i, i])
    return keep
