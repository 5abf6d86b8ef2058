r"""Compiled (numba) kernels of the IMM's prediction (steps 1-4) and fused output (step 7).

The same equations as the numpy functions of ``imm.py`` (``mix``, the mode-matched prediction
and ``merge``), which the tests compare against, looped per batch item so a Gaussian sum of a
few 10-state IMMs is predicted in microseconds instead of ~100 small numpy calls::

    c_j = max(sum_i Pi_ij mu_i, 1e-300),   w_ij = Pi_ij mu_i / c_j
    x0_j = sum_i w_ij T_j(x_i),   P0_j = sum_i w_ij (T_j(P_i) + (T_j(x_i) - x0_j)(..)^T)
    x_j = F_j x0_j,   P_j = F_j P0_j F_j^T + Q_j,   mu_j = c_j / sum_l c_l
    update: mu_j <- c_j Lambda_j / sum_l c_l Lambda_l   (in logs)
    merge: x = sum_j mu_j T(x_j),   P = sum_j mu_j (T(P_j) + (T(x_j) - x)(..)^T)

A conversion T (``motion_models.convert``) is given as an index map ``src``: row r of the
target state is row ``src[r]`` of the source state, or a lifted acceleration (``src[r] < 0``)
with zero mean, variance ``lift_var[r]`` and no correlation. Modes are passed as tuples of
arrays (one per mode; the sizes differ). After editing, delete
``ridsafe/gcs/tracking/__pycache__/*.nb[ci]`` (numba's cache does not track other modules).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.int64]

__all__ = [
    "accumulate",
    "merge_batch",
    "mixture_moments",
    "mode_probabilities",
    "predict_batch",
]


@jit
def _convert(
    x: FloatArray,
    P: FloatArray,
    h: int,
    src: IndexArray,
    lift_var: FloatArray,
    xc: FloatArray,
    Pc: FloatArray,
) -> None:
    """Batch item ``h`` of (x (H, n), P (H, n, n)) in the target space of ``src`` -> xc, Pc."""
    n = xc.shape[0]
    for r in range(n):
        a = src[r]
        if a < 0:
            xc[r] = 0.0
            for c in range(n):
                Pc[r, c] = 0.0
            Pc[r, r] = lift_var[r]
            continue
        xc[r] = x[h, a]
        for c in range(n):
            b = src[c]
            Pc[r, c] = P[h, a, b] if b >= 0 else 0.0


@jit
def accumulate(
    weight: float, xc: FloatArray, Pc: FloatArray, mean: FloatArray, P: FloatArray
) -> None:
    """P += weight (Pc + (xc - mean)(xc - mean)^T)."""
    n = xc.shape[0]
    for r in range(n):
        dr = xc[r] - mean[r]
        for c in range(n):
            P[r, c] += weight * (Pc[r, c] + dr * (xc[c] - mean[c]))


@jit
def mixture_moments(
    weights: FloatArray, x: FloatArray, P: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The moments of a weighted batch of Gaussians, the covariance symmetrised;
    ``x`` (H, n), ``P`` (H, n, n) -> (n,), (n, n)."""
    H, n = x.shape
    mean = np.zeros(n)
    for h in range(H):
        for r in range(n):
            mean[r] += weights[h] * x[h, r]
    cov = np.zeros((n, n))
    for h in range(H):
        accumulate(weights[h], x[h], P[h], mean, cov)
    return mean, 0.5 * (cov + cov.T)


@jit
def _mixed_start(
    xs: Any,
    Ps: Any,
    h: int,
    weights: FloatArray,
    src: IndexArray,
    lift_var: FloatArray,
    n: int,
) -> tuple[FloatArray, FloatArray]:
    """x0, P0 (symmetrised) of one target mode: ``weights`` (M,) over the source modes,
    ``src`` (M, n_max) and ``lift_var`` (n_max,) the conversions into the target."""
    M = weights.shape[0]
    convs_x = np.empty((M, n))
    convs_P = np.empty((M, n, n))
    for i in range(M):
        _convert(xs[i], Ps[i], h, src[i], lift_var, convs_x[i], convs_P[i])
    return mixture_moments(weights, convs_x, convs_P)


@jit
def predict_batch(
    xs: Any,
    Ps: Any,
    mu: FloatArray,
    Pi: FloatArray,
    src: IndexArray,
    lift_var: FloatArray,
    Fs: Any,
    Qs: Any,
    xs_out: Any,
    Ps_out: Any,
    mu_out: FloatArray,
) -> None:
    """Steps 1-4 for every batch item. ``xs``/``Ps``: per mode (H, n_j) / (H, n_j, n_j);
    ``src`` (M, M, n_max): target j <- source i index maps; ``lift_var`` (M, n_max);
    ``Fs``/``Qs`` per mode over the interval. Writes ``xs_out``, ``Ps_out``, ``mu_out``."""
    H, M = mu.shape
    w = np.empty(M)
    c = np.empty(M)
    for h in range(H):
        for j in range(M):
            s = 0.0
            for i in range(M):
                s += mu[h, i] * Pi[i, j]
            c[j] = max(s, 1e-300)
        for j in range(M):
            for i in range(M):
                w[i] = Pi[i, j] * mu[h, i] / c[j]
            n = xs_out[j].shape[1]
            x0, P0 = _mixed_start(xs, Ps, h, w, src[j], lift_var[j], n)
            F = Fs[j]
            xs_out[j][h] = F @ x0
            P = F @ P0 @ F.T + Qs[j]
            Ps_out[j][h] = 0.5 * (P + P.T)
        total = c.sum()
        for j in range(M):
            mu_out[h, j] = c[j] / total


@jit
def merge_batch(
    xs: Any,
    Ps: Any,
    mu: FloatArray,
    src: IndexArray,
    lift_var: FloatArray,
    x_out: FloatArray,
    P_out: FloatArray,
) -> None:
    """Step 7 for every batch item: ``src`` (M, n_max) the conversions into the output
    space, ``lift_var`` (n_max,). Writes ``x_out`` (H, n), ``P_out`` (H, n, n)."""
    H = mu.shape[0]
    n = x_out.shape[1]
    for h in range(H):
        x, P = _mixed_start(xs, Ps, h, mu[h], src, lift_var, n)
        x_out[h] = x
        P_out[h] = P


@jit
def mode_probabilities(mu: FloatArray, log_lik: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Step 6 in logs for every batch item: mu_j <- c_j Lambda_j / sum_l c_l Lambda_l, and
    log sum_j c_j Lambda_j; ``mu`` (H, M) the predicted probabilities, ``log_lik`` (H, M)."""
    H, M = mu.shape
    out = np.empty((H, M))
    total = np.empty(H)
    for h in range(H):
        top = -np.inf
        for j in range(M):
            out[h, j] = math.log(max(mu[h, j], 1e-300)) + log_lik[h, j]
            top = max(top, out[h, j])
        s = 0.0
        for j in range(M):
            out[h, j] = math.exp(out[h, j] - top)
            s += out[h, j]
        total[h] = top + math.log(s)
        for j in range(M):
            out[h, j] /= s
    return out, total
