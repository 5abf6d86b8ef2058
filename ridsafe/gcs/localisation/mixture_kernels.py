r"""Compiled (numba) kernels of the Gaussian sum's bookkeeping (``gaussian_sum.py``).

Every update of the sum moment-matches it, tests each hypothesis for a split and every pair
for a merge; in numpy each is a dozen calls on arrays of a few 3 x 3 blocks. Here (the
tests compare each against numpy)::

    moments:      x = sum_h w_h x_h,   P = sum_h w_h (P_h + (x_h - x)(x_h - x)^T)
                  (shared with the IMM's mixing: ``imm_kernels.mixture_moments``)
    curvature:    (20/ln10) lambda_max(P_h,pos) / (2 max(d_min,h^2, 1)),  d_min,h the distance
                  from x_h,pos to the nearest receiver; and the principal axis e_h
    pairs:        m2_ab = (p_a - p_b)^T (C_a + C_b)^-1 (p_a - p_b) for a < b, inf elsewhere
                  (and where C_a + C_b is not positive definite: such a pair never merges)

The pair distance is a compiled twin of ``ridsafe.common.ellipsoid.mahalanobis2`` (the one
reference), tested against it. After editing, delete
``ridsafe/gcs/localisation/__pycache__/*.nb[ci]`` (numba's cache does not track other modules).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit
from ridsafe.common.pathloss import DB_PER_LN
from ridsafe.gcs.tracking.imm_kernels import mixture_moments

FloatArray = NDArray[np.float64]

__all__ = ["mixture_moments", "pair_mahalanobis2", "split_curvature"]


@jit
def split_curvature(x: FloatArray, P: FloatArray, rx: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Each hypothesis' curvature of the RSSI over its position spread (dB) and the principal
    axis of its position covariance: (H,), (H, 3); ``x`` (H, n), ``P`` (H, n, n) with the
    position first, ``rx`` (k, 3)."""
    H = x.shape[0]
    curvature = np.empty(H)
    axis = np.empty((H, 3))
    for h in range(H):
        lam, V = np.linalg.eigh(np.ascontiguousarray(P[h, :3, :3]))
        d2 = math.inf
        for i in range(rx.shape[0]):
            e = (x[h, 0] - rx[i, 0]) ** 2 + (x[h, 1] - rx[i, 1]) ** 2 + (x[h, 2] - rx[i, 2]) ** 2
            d2 = min(d2, e)
        curvature[h] = 0.5 * DB_PER_LN * lam[2] / max(d2, 1.0)
        axis[h] = V[:, 2]
    return curvature, axis


@jit
def _mahalanobis2_3(d: FloatArray, S: FloatArray) -> float:
    """d^T S^-1 d for a 3 x 3 ``S`` by its Cholesky factor; inf if S is not positive
    definite."""
    L = np.zeros((3, 3))
    for i in range(3):
        for j in range(i + 1):
            acc = S[i, j]
            for m in range(j):
                acc -= L[i, m] * L[j, m]
            if i == j:
                if not acc > 0.0:
                    return math.inf
                L[i, i] = math.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
    out = 0.0
    w = np.empty(3)  # L^-1 d
    for i in range(3):
        acc = d[i]
        for j in range(i):
            acc -= L[i, j] * w[j]
        w[i] = acc / L[i, i]
        out += w[i] * w[i]
    return out


@jit
def pair_mahalanobis2(p: FloatArray, C: FloatArray) -> FloatArray:
    """m2[a, b] between the positions ``p`` (H, 3) with covariances ``C`` (H, 3, 3) for
    a < b; inf on and below the diagonal (and where C_a + C_b is not positive definite)."""
    H = p.shape[0]
    m2 = np.full((H, H), np.inf)
    for a in range(H):
        for b in range(a + 1, H):
            m2[a, b] = _mahalanobis2_3(p[a] - p[b], C[a] + C[b])
    return m2
