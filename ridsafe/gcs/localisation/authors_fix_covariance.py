r"""The covariance the authors' code gives a position-only RSSI fix (docs/paper_mode.md, item
"Measurement covariance"; the paper's text says R_CV = 400 I, R_CA = 50 I instead).

For receivers r_i (k, 3), the fix p and its RSSI residuals e (dB, at the tracked power):

    J_i   = -(20 / ln 10) (p - r_i) / ||p - r_i||^2                       (k, 3)
    s^2   = max(sum e^2 / max(1, k - 3), 1e-3)
    C_0   = eigclip(s^2 (J^T J)^-1, 1, 1600)                            Gauss-Newton, m^2
    rho   = sigma_min / sigma_max of the centred receiver positions (singular values)
    g_geo = clip(1 + 2 (1 - rho)^2, 1, 3);  span = max(sigma_max, 1)
    d     = median_i max(||p - r_i||, 1)
    g_rng = clip(d / span, 1, 3);  g = clip((g_geo + g_rng) / 2, 1, 3)
    s_mod = min((ln 10 / 20) d (std(e) + |median(e)|) sqrt(g), 20)           m
    C     = eigclip(g (C_0 + s_mod^2 I), 2.25, 2500)

``eigclip(M, lo, hi)`` clips the eigenvalues of the symmetrised M to [lo, hi]. The result has
a std between 1.5 and 50 m whatever the geometry.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["authors_fix_covariance", "eigclip"]

_DB_PER_LN = 20.0 / math.log(10.0)


def eigclip(M: FloatArray, lo: float, hi: float) -> FloatArray:
    """Symmetrised ``M`` with its eigenvalues clipped to [lo, hi] (its diagonal clipped, when
    it has no eigen-decomposition)."""
    try:
        lam, V = np.linalg.eigh(0.5 * (M + M.T))
    except np.linalg.LinAlgError:
        return np.diag(np.clip(np.nan_to_num(np.diag(M), nan=lo), lo, hi))
    out: FloatArray = (V * np.clip(lam, lo, hi)) @ V.T
    return 0.5 * (out + out.T)


def authors_fix_covariance(
    rx_enu_m: FloatArray, p_enu_m: FloatArray, residual_db: FloatArray
) -> FloatArray:
    """(3, 3) covariance of a position-only fix ``p_enu_m`` from ``rx_enu_m : (k, 3)`` with
    RSSI residuals ``residual_db : (k,)`` (module docstring)."""
    k = rx_enu_m.shape[0]
    diff = p_enu_m - rx_enu_m
    d2 = np.maximum(np.sum(diff**2, axis=1), 1e-4)
    J = -_DB_PER_LN * diff / d2[:, None]
    s2 = max(float(residual_db @ residual_db) / max(1, k - 3), 1e-3)
    c0 = eigclip(s2 * np.linalg.pinv(J.T @ J), 1.0, 1600.0)
    sv = np.linalg.svd(rx_enu_m - rx_enu_m.mean(axis=0), compute_uv=False)
    s_max, s_min = max(float(sv[0]), 1e-6), max(float(sv[-1]), 1e-6)
    rho = min(max(s_min / s_max, 0.0), 1.0)
    g_geo = min(max(1.0 + 2.0 * (1.0 - rho) ** 2, 1.0), 3.0)
    d_med = float(np.median(np.maximum(np.sqrt(np.sum(diff**2, axis=1)), 1.0)))
    g_rng = min(max(d_med / max(s_max, 1.0), 1.0), 3.0)
    g = min(max(0.5 * (g_geo + g_rng), 1.0), 3.0)
    spread_db = float(np.std(residual_db)) + abs(float(np.median(residual_db)))
    s_mod = min(d_med * spread_db / _DB_PER_LN * math.sqrt(g), 20.0)
    return eigclip(g * (c0 + np.eye(3) * s_mod**2), 2.25, 2500.0)
