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
A^T = L^-T G, A C A^T = G^T G.

Nor with any k x k matrix (k receivers; factorising one costs k^3 / 3 multiply-adds): pairing
the points c and c + 4, Phi = G^T G + E^T E with E_c = (dZ_c + dZ_{c+4}) / 4, so
Omega = E^T E has rank 4, and with R = diag(d)::

    S = A Puu A^T + Omega + R = D + V V^T,    V = [A chol(Puu) | E^T]   (k x 8)
    S^-1 X = D^-1 X - D^-1 V M^-1 V^T D^-1 X,  M = I + V^T D^-1 V      (8 x 8, eigenvalues >= 1)
    log det S = sum log d + log det M                (Woodbury; the matrix determinant lemma)

so an update costs O(k) and the linearisation keeps (A, b, d, E), not R + Omega.

The on-disk cache does not notice edits in other modules a kernel calls: after editing,
delete ``ridsafe/gcs/localisation/__pycache__/*.nb[ci]``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

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
    """A (k, 4), b (k,) and E (4, k), Omega = E^T E (module docstring). With C = L L^T and
    the points m +/- 2 L e_c, Psi = L G where G[c] = (dZ[c] - dZ[c+4]) / 4, so
    A^T = C^-1 Psi = L^-T G (no solve with C)."""
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
    G = np.empty((4, k))
    E = np.empty((4, k))
    for c in range(4):
        for i in range(k):
            G[c, i] = 0.25 * (Z[c, i] - Z[c + 4, i])
            E[c, i] = 0.25 * (Z[c, i] + Z[c + 4, i]) - 0.5 * z_bar[i]
    A = _upper_solve(L, G).T.copy()  # (k, 4)
    b = z_bar - A @ mean
    return A, b, E


@jit
def _noise(mean: FloatArray, rx: FloatArray, s2: float, rx2: float) -> FloatArray:
    """R's diagonal d (k,) at ``mean``: s^2 + rx2 / d_i^2."""
    d2 = _distances2(mean, rx)
    out = np.empty(rx.shape[0])
    for i in range(rx.shape[0]):
        out[i] = s2 + rx2 / d2[i]
    return out


@jit
def _innovation_factors(
    A: FloatArray, Puu: FloatArray, d: FloatArray, E: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.floating[Any]], float]:
    """S = D + V V^T (module docstring): V (k, 8), D^-1 V, the Cholesky factor of
    M = I + V^T D^-1 V, and log det S."""
    k = d.shape[0]
    Lp = np.linalg.cholesky(Puu)
    AL = A @ Lp  # (k, 4)
    V = np.empty((k, 8))
    Vd = np.empty((k, 8))
    log_det = 0.0
    for i in range(k):
        for c in range(4):
            V[i, c] = AL[i, c]
            V[i, c + 4] = E[c, i]
        for c in range(8):
            Vd[i, c] = V[i, c] / d[i]
        log_det += math.log(d[i])
    M = V.T @ Vd
    for c in range(8):
        M[c, c] += 1.0
    Lm = np.linalg.cholesky(0.5 * (M + M.T))
    for c in range(8):
        log_det += 2.0 * math.log(Lm[c, c])
    return V, Vd, Lm, log_det


@jit
def _solve_innovation(
    X: FloatArray, d: FloatArray, V: FloatArray, Vd: FloatArray, Lm: NDArray[np.floating[Any]]
) -> FloatArray:
    """S^-1 X for X (k, m) (Woodbury, module docstring)."""
    Y = np.empty_like(X)
    for i in range(X.shape[0]):
        for c in range(X.shape[1]):
            Y[i, c] = X[i, c] / d[i]
    W = _upper_solve(Lm, _lower_solve(Lm, V.T @ Y))  # M^-1 V^T D^-1 X  (8, m)
    return Y - Vd @ W


@jit
def _update(
    u0: FloatArray,
    Puu: FloatArray,
    A: FloatArray,
    b: FloatArray,
    d: FloatArray,
    E: FloatArray,
    z: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    APuu = A @ Puu  # (k, 4)
    V, Vd, Lm, _ = _innovation_factors(A, Puu, d, E)
    K = _solve_innovation(APuu, d, V, Vd, Lm).T.copy()  # (4, k) = Puu A^T S^-1
    nu = z - A @ u0 - b
    mean = u0 + K @ nu
    cov = Puu - K @ APuu
    return mean, 0.5 * (cov + cov.T)


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
            A, b, E = _slr(m, c, rx, loss)
            d = _noise(m, rx, s2, rx2)
            m_new, c_new = _update(u0[h], Puu[h], A, b, d, E, z)
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
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """SLR of every batch item over its observed block's posterior: A (B, k, 4), b (B, k),
    R's diagonal d (B, k) and E (B, 4, k) with Omega = E^T E; every mode of a hypothesis is
    updated with the same."""
    B, k = post_mean.shape[0], rx.shape[0]
    A_out = np.empty((B, k, 4))
    b_out = np.empty((B, k))
    d_out = np.empty((B, k))
    E_out = np.empty((B, 4, k))
    for h in range(B):
        A, b, E = _slr(post_mean[h], post_cov[h], rx, loss)
        A_out[h] = A
        b_out[h] = b
        d_out[h] = _noise(post_mean[h], rx, s2, rx2)
        E_out[h] = E
    return A_out, b_out, d_out, E_out


@jit
def iplf_final(
    x0: FloatArray,
    P0: FloatArray,
    i_pt: int,
    A_all: FloatArray,
    b_all: FloatArray,
    d_all: FloatArray,
    E_all: FloatArray,
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
        A, b, d, E = A_all[h], b_all[h], d_all[h], E_all[h]
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
        V, Vd, Lm, log_det = _innovation_factors(A, Puu, d, E)
        K = _solve_innovation(APux, d, V, Vd, Lm).T.copy()  # (n, k) = P_xu A^T S^-1
        nu = z - A @ u0 - b
        x_out[h] = x0[h] + K @ nu
        KA = K @ A  # (n, 4)
        IKH = np.eye(n)
        for r in range(4):
            IKH[:, idx[r]] -= KA[:, r]
        KD = np.empty((n, k))  # K R K^T + K E^T E K^T: R + Omega without forming it
        for r in range(n):
            for i in range(k):
                KD[r, i] = K[r, i] * d[i]
        KE = K @ E.T  # (n, 4)
        P = IKH @ P0[h] @ IKH.T + KD @ K.T + KE @ KE.T
        P_out[h] = 0.5 * (P + P.T)
        nu_col = np.empty((k, 1))
        nu_col[:, 0] = nu
        quad = float(np.sum(nu * _solve_innovation(nu_col, d, V, Vd, Lm)[:, 0]))
        loglik[h] = -0.5 * (quad + log_det + k * _LOG_2PI)
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
    A, b, E = _slr(mean, cov, rx, loss)
    d = _noise(mean, rx, s2, rx2)
    h = A @ mean + b
    AC = A @ cov
    keep = np.empty(rx.shape[0], dtype=np.bool_)
    for i in range(rx.shape[0]):
        s_ii = d[i]
        for c in range(4):
            s_ii += AC[i, c] * A[i, c] + E[c, i] * E[c, i]
        keep[i] = abs(z[i] - h[i]) <= gate_sigma * math.sqrt(s_ii)
    return keep
