r"""Compiled (numba) kernels of the iterated posterior linearisation in ``rssi_update.py``.

The same equations as the numpy reference there (which the tests compare against), looped
per batch item so a 16-receiver update costs microseconds instead of numpy's per-call
overhead:

    SLR over N(m, C) with cubature points m +/- 2 chol(C) e_l:   A = Psi^T C^-1,
    b = z_bar - A m,  Omega = Phi - A C A^T;
    update of N(u0, Puu) by z = A u + b + N(0, R + Omega):       S = A Puu A^T + R + Omega,
    K = Puu A^T S^-1,  m+ = u0 + K (z - A u0 - b),  C+ = Puu - K A Puu.

Computed without general solves (LAPACK's LU costs microseconds at these sizes): with
C = L L^T the points are m +/- 2 L e_c, so Psi = L G with G_c = (dZ_c - dZ_{c+4}) / 4 and
A^T = L^-T G, A C A^T = G^T G; S^-1 comes from its Cholesky factor by substitution.

The on-disk cache does not notice edits in other modules a kernel calls: after editing,
delete ``ridsafe/gcs/localisation/__pycache__/*.nb[ci]``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.jit import jit

FloatArray = NDArray[np.float64]

__all__ = ["gate", "iplf_final", "iplf_iterate_batch", "linearise_batch"]

_LOG_2PI = math.log(2.0 * math.pi)


@jit
def _distances2(p: FloatArray, rx: FloatArray) -> FloatArray:
    k = rx.shape[0]
    out = np.empty(k)
    for i in range(k):
        d2 = (p[0] - rx[i, 0]) ** 2 + (p[1] - rx[i, 1]) ** 2 + (p[2] - rx[i, 2]) ** 2
        out[i] = max(d2, 1.0)
    return out


@jit
def _lower_solve(L: NDArray[np.floating[Any]], B: FloatArray) -> FloatArray:
    """L^-1 B by forward substitution (L lower triangular (k, k), B (k, m))."""
    k, m = B.shape
    X = B.copy()
    for i in range(k):
        for j in range(i):
            f = L[i, j]
            for c in range(m):
                X[i, c] -= f * X[j, c]
        for c in range(m):
            X[i, c] /= L[i, i]
    return X


@jit
def _upper_solve(L: NDArray[np.floating[Any]], B: FloatArray) -> FloatArray:
    """L^-T B by back substitution (L lower triangular (k, k), B (k, m))."""
    k, m = B.shape
    X = B.copy()
    for i in range(k - 1, -1, -1):
        for j in range(i + 1, k):
            f = L[j, i]
            for c in range(m):
                X[i, c] -= f * X[j, c]
        for c in range(m):
            X[i, c] /= L[i, i]
    return X


@jit
def _slr(mean: FloatArray, cov: FloatArray, rx: FloatArray, loss: float) -> tuple[Any, Any, Any]:
    """With C = L L^T and the points m +/- 2 L e_c, Psi = L G where G[c] = (dZ[c] - dZ[c+4]) / 4,
    so A^T = C^-1 Psi = L^-T G and A C A^T = G^T G (no solve with C)."""
    k = rx.shape[0]
    L = np.linalg.cholesky(cov)
    pts = np.empty((8, 4))
    for col in range(4):
        for r in range(4):
            pts[col, r] = mean[r] + 2.0 * L[r, col]
            pts[col + 4, r] = mean[r] - 2.0 * L[r, col]
    Z = np.empty((8, k))
    for m in range(8):
        d2 = _distances2(pts[m], rx)
        for i in range(k):
            Z[m, i] = pts[m, 3] - 10.0 * math.log10(d2[i]) - loss
    z_bar = np.zeros(k)
    for m in range(8):
        z_bar += Z[m]
    z_bar /= 8.0
    dZ = Z - z_bar
    G = np.empty((4, k))
    for c in range(4):
        for i in range(k):
            G[c, i] = 0.25 * (dZ[c, i] - dZ[c + 4, i])
    Phi = dZ.T @ dZ / 8.0  # (k, k)
    A = _upper_solve(L, G).T.copy()  # (k, 4)
    b = z_bar - A @ mean
    Omega = Phi - G.T @ G
    Omega = 0.5 * (Omega + Omega.T)
    return A, b, Omega


@jit
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
    L = np.linalg.cholesky(S)
    K = _upper_solve(L, _lower_solve(L, APuu)).T.copy()  # (4, k) = Puu A^T S^-1
    nu = z - A @ u0 - b
    mean = u0 + K @ nu
    cov = Puu - K @ APuu
    return mean, 0.5 * (cov + cov.T)


@jit
def _with_r(
    Omega: FloatArray, mean: FloatArray, rx: FloatArray, s2: float, rx2: float
) -> FloatArray:
    d2 = _distances2(mean, rx)
    Rt = Omega.copy()
    for i in range(rx.shape[0]):
        Rt[i, i] += s2 + rx2 / d2[i]
    return Rt


@jit
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


@jit
def linearise_batch(
    post_mean: FloatArray,
    post_cov: FloatArray,
    rx: FloatArray,
    s2: float,
    rx2: float,
    loss: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """SLR of every batch item over its observed block's posterior: (A (B, k, 4), b (B, k),
    R + Omega (B, k, k)); every mode of a hypothesis is updated with the same."""
    B, k = post_mean.shape[0], rx.shape[0]
    A_out = np.empty((B, k, 4))
    b_out = np.empty((B, k))
    Rt_out = np.empty((B, k, k))
    for h in range(B):
        A, b, Omega = _slr(post_mean[h], post_cov[h], rx, loss)
        A_out[h] = A
        b_out[h] = b
        Rt_out[h] = _with_r(Omega, post_mean[h], rx, s2, rx2)
    return A_out, b_out, Rt_out


@jit
def iplf_final(
    x0: FloatArray,
    P0: FloatArray,
    i_pt: int,
    A_all: FloatArray,
    b_all: FloatArray,
    Rt_all: FloatArray,
    z: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Whole-state update of each batch item with its linearisation (``linearise_batch``);
    Joseph form; (x (B, n), P (B, n, n), log-likelihood (B,))."""
    B, n = x0.shape
    k = z.shape[0]
    idx = np.array([0, 1, 2, i_pt])
    x_out = np.empty_like(x0)
    P_out = np.empty_like(P0)
    loglik = np.empty(B)
    for h in range(B):
        A, b, Rt = A_all[h], b_all[h], Rt_all[h]
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
        K = _upper_solve(L, _lower_solve(L, APux)).T.copy()  # (n, k) = P_xu A^T S^-1
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


@jit
def gate(
    x: FloatArray,
    P: FloatArray,
    i_pt: int,
    rx: FloatArray,
    z: FloatArray,
    s2: float,
    rx2: float,
    loss: float,
    gate_sigma: float,
) -> NDArray[np.bool_]:
    """|z_i - (A m + b)_i| <= gate_sigma sqrt(S_ii), S_ii = (A C A^T + Omega)_ii + R_i, with
    (m, C) the observed block (p, Pt at ``i_pt``) of the state (x (n,), P (n, n))."""
    idx = np.array([0, 1, 2, i_pt])
    mean = np.empty(4)
    cov = np.empty((4, 4))
    for r in range(4):
        mean[r] = x[idx[r]]
        for c in range(4):
            cov[r, c] = P[idx[r], idx[c]]
    A, b, Omega = _slr(mean, cov, rx, loss)
    Rt = _with_r(Omega, mean, rx, s2, rx2)
    h = A @ mean + b
    ACA = A @ cov @ A.T
    keep = np.empty(rx.shape[0], dtype=np.bool_)
    for i in range(rx.shape[0]):
        keep[i] = abs(z[i] - h[i]) <= gate_sigma * math.sqrt(ACA[i, i] + Rt[i, i])
    return keep
