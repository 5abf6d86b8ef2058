"""The planner's scene, compiled: hazards projected over the rollout times and those that
cannot matter dropped (:func:`ridsafe.companion.planner_eval.build_scene` says what and
why; value eq. 5 for the regions).

Every number is computed with the operations, in the order, of the array expressions
these replace (``tests/companion/test_scene_kernel.py`` holds them side by side), so a
decision does not depend on which computed its scene.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

__all__ = ["project_neighbours", "project_regions"]

FloatArray = NDArray[np.float64]


@jit
def project_neighbours(
    rows: FloatArray,
    now_s: float,
    tau_s: FloatArray,
    p0: FloatArray,
    d_safe_m: float,
    max_speed_m_s: float,
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Neighbour j (``rows[j]``: position q_j, velocity w_j, receive time t_j) at
    q_j + w_j ((now - t_j) + tau_k) : (N, K, 3), and whether it comes within
    d_safe + v_max tau_k of p0 at some k : (N,) (never, for a row with a NaN or an inf: its
    distance is NaN or inf, and the strict ``<`` is false for both)."""
    n, n_k = rows.shape[0], tau_s.shape[0]
    pos = np.empty((n, n_k, 3))
    keep = np.zeros(n, dtype=np.bool_)
    for j in range(n):
        age = now_s - rows[j, 6]
        for k in range(n_k):
            horizon = age + tau_s[k]
            x = rows[j, 0] + rows[j, 3] * horizon
            y = rows[j, 1] + rows[j, 4] * horizon
            z = rows[j, 2] + rows[j, 5] * horizon
            pos[j, k, 0], pos[j, k, 1], pos[j, k, 2] = x, y, z
            dx, dy, dz = x - p0[0], y - p0[1], z - p0[2]
            if math.sqrt(dx * dx + dy * dy + dz * dz) < d_safe_m + max_speed_m_s * tau_s[k]:
                keep[j] = True
    return pos, keep


@jit
def project_regions(
    center0: FloatArray,
    velocity: FloatArray,
    eigenvalues: FloatArray,
    eigenvectors: FloatArray,
    age_s: FloatArray,
    tau_s: FloatArray,
    sigma_v_m_s: float,
    p0: FloatArray,
    sqrt_chi2: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Region r predicted tau_k ahead (value eq. 5), tau_k >= -age_r held at the estimate:
    centres (R, K, 3), P(tau)^-1 (R, K, 3, 3), sqrt(lambda_min(P(tau))) (R, K), and p0's
    distance to each predicted ellipsoid (value eq. 4) (R, K)."""
    n_r, n_k = center0.shape[0], tau_s.shape[0]
    center = np.empty((n_r, n_k, 3))
    pinv = np.empty((n_r, n_k, 3, 3))
    sigma = np.empty((n_r, n_k))
    distance = np.empty((n_r, n_k))
    inverse = np.empty(3)
    for r in range(n_r):
        for k in range(n_k):
            horizon = max(age_s[r] + tau_s[k], 0.0)
            grown = (sigma_v_m_s * horizon) * (sigma_v_m_s * horizon)
            smallest = np.inf
            for j in range(3):
                center[r, k, j] = center0[r, j] + velocity[r, j] * horizon
                lam = eigenvalues[r, j] + grown
                inverse[j] = 1.0 / lam
                smallest = min(smallest, lam)
            for i in range(3):
                for m in range(3):
                    acc = 0.0
                    for j in range(3):
                        acc += eigenvectors[r, i, j] * inverse[j] * eigenvectors[r, m, j]
                    pinv[r, k, i, m] = acc
            sigma[r, k] = math.sqrt(smallest)
            mahalanobis2 = 0.0
            for i in range(3):
                for m in range(3):
                    mahalanobis2 += (
                        (p0[i] - center[r, k, i]) * pinv[r, k, i, m] * (p0[m] - center[r, k, m])
                    )
            root = math.sqrt(max(mahalanobis2, 0.0))
            distance[r, k] = sigma[r, k] * max(0.0, root - sqrt_chi2[r])
    return center, pinv, sigma, distance
