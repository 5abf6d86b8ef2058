"""The FastMDP-style value of a state: reward sources that decay with distance.

Paper section 5 (Table 4, after Taye et al. 2024 "FastMDP"); every source i has a reward R_i, a
decay gamma_i and a gating radius L_i, and contributes at distance d_i (metres)::

    V_i(s) = 1[d_i < L_i] * R_i / (1 - gamma_i^2) * gamma_i^d_i                       (1)

    V(s)   = max_{goal sources} V_i(s)  +  min_{hazard sources} V_j(s)                (2)

(goal rewards are > 0, hazard rewards < 0, so (2) is "best goal term minus worst hazard term";
with no hazard within its gate the second term is 0).

Hazards:

- another aircraft j, a benign-conflict source gated by L = d_safe::

      R_j(t) = R_base + R_rate * t          (paper: -(100 t + 500))                   (3)

  where t (our choice; the paper does not say) is the time in seconds that the rollout has
  already spent within d_safe of aircraft j before this sample: a conflict that persists costs
  more the longer it lasts, a brief one costs R_base.

- an unsafe region (x - c)^T P^-1 (x - c) <= chi2 (paper eq. 10), with distance::

      m(x) = (x - c)^T P^-1 (x - c)
      d(x) = sqrt(lambda_min(P)) * max(0, sqrt(m(x)) - sqrt(chi2))                      (4)

  a lower bound of the Euclidean distance from x to the ellipsoid (0 inside), exact for a
  sphere: for y on the surface, |x - y| >= sqrt(lambda_min) |x - y|_P and, by the triangle
  inequality in the P-norm, |x - y|_P >= sqrt(m(x)) - sqrt(chi2). Being conservative, it never
  lets a rollout closer to the region than the shield margin says.

Regions move with the estimated spoofer velocity v and grow with prediction time
tau = t_now - t_estimate + rollout time (our choice, sigma_v in m/s)::

      c(tau) = c + v tau,        P(tau) = P + (sigma_v tau)^2 I                         (5)

Functions here are plain numpy over any leading shape; the compiled rollout kernel in
:mod:`ridsafe.companion.planner_kernel` implements the same equations and is tested against them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ridsafe.common.ellipsoid import mahalanobis2

__all__ = [
    "benign_reward",
    "predicted_region",
    "region_distance_m",
    "region_intrusion_m",
    "region_signed_distance_m",
    "source_coefficient",
    "source_value",
    "state_value",
]

FloatArray = NDArray[np.float64]


def source_coefficient(reward: float, decay: float) -> float:
    """R / (1 - gamma^2): the value of source (1) at distance 0."""
    return reward / (1.0 - decay * decay)


def source_value(reward: ArrayLike, decay: float, gate_m: float, d_m: ArrayLike) -> FloatArray:
    """Eq. (1) for distances ``d_m`` (any shape; ``reward`` broadcasts against it)."""
    d = np.asarray(d_m, dtype=np.float64)
    r = np.asarray(reward, dtype=np.float64)
    value: FloatArray = np.where(d < gate_m, r / (1.0 - decay * decay) * decay**d, 0.0)
    return value


def benign_reward(base: float, rate_per_s: float, conflict_s: ArrayLike) -> FloatArray:
    """Eq. (3): the reward of a benign conflict that has lasted ``conflict_s`` seconds."""
    reward: FloatArray = base + rate_per_s * np.asarray(conflict_s, dtype=np.float64)
    return reward


def region_signed_distance_m(
    x_m: ArrayLike, center_m: ArrayLike, cov_m2: ArrayLike, chi2: float
) -> FloatArray:
    """sigma_min (sqrt(m) - sqrt(chi2)) for points ``x_m : (..., 3)``: eq. (4) before its
    clamp at 0, negative inside the ellipsoid (its depth there, in the same metres).

    ``cov_m2 : (3, 3)`` must be symmetric positive definite.
    """
    delta, cov, sigma_min = _region_frame(x_m, center_m, cov_m2)
    return _beyond_surface_m(mahalanobis2(delta, cov), sigma_min, chi2)


def _region_frame(
    x_m: ArrayLike, center_m: ArrayLike, cov_m2: ArrayLike
) -> tuple[FloatArray, FloatArray, float]:
    """(offsets from the centre, the covariance, sqrt of its smallest eigenvalue)."""
    cov = np.asarray(cov_m2, dtype=np.float64)
    delta = np.asarray(x_m, dtype=np.float64) - np.asarray(center_m, dtype=np.float64)
    return delta, cov, float(np.sqrt(np.linalg.eigvalsh(cov)[0]))


def _beyond_surface_m(m: FloatArray, sigma_min: float, chi2: float) -> FloatArray:
    """sigma_min (sqrt(m) - sqrt(chi2)) for Mahalanobis^2 values ``m``: < 0 inside."""
    beyond: FloatArray = sigma_min * (np.sqrt(np.maximum(m, 0.0)) - np.sqrt(chi2))
    return beyond


def region_distance_m(
    x_m: ArrayLike, center_m: ArrayLike, cov_m2: ArrayLike, chi2: float
) -> FloatArray:
    """Eq. (4): conservative distance (m) from points ``x_m : (..., 3)`` to the ellipsoid
    (0 inside it).

    ``cov_m2 : (3, 3)`` must be symmetric positive definite.
    """
    dist: FloatArray = np.maximum(0.0, region_signed_distance_m(x_m, center_m, cov_m2, chi2))
    return dist


def region_intrusion_m(
    x_m: ArrayLike, center_m: ArrayLike, cov_m2: ArrayLike, chi2: float, threshold_m: float
) -> FloatArray:
    """The shield's intrusion (m) of points ``x_m : (..., 3)`` into the region: outside the
    ellipsoid ``max(0, threshold - s)`` (``s`` = eq. 4), inside it ``threshold`` plus the
    point's horizontal depth, sigma_min (sqrt(chi2) - sqrt(m_h)) with m_h the Mahalanobis
    distance of the horizontal offset under the horizontal marginal (its covariance's upper
    2 x 2 block). Horizontal because the way out of a region that spans the altitude band is
    sideways: a vertical exit counts once it is made (the sample is outside).
    """
    delta, cov, sigma_min = _region_frame(x_m, center_m, cov_m2)
    signed = _beyond_surface_m(mahalanobis2(delta, cov), sigma_min, chi2)
    m_h = mahalanobis2(delta[..., :2], cov[:2, :2])  # under the horizontal marginal
    depth = np.maximum(0.0, -_beyond_surface_m(m_h, sigma_min, chi2))
    intrusion: FloatArray = np.where(
        signed >= 0.0, np.maximum(0.0, threshold_m - signed), threshold_m + depth
    )
    return intrusion


def predicted_region(
    center_m: ArrayLike, v_m_s: ArrayLike, cov_m2: ArrayLike, sigma_v_m_s: float, tau_s: float
) -> tuple[FloatArray, FloatArray]:
    """Eq. (5): the region's (centre (3,), covariance (3, 3)) ``tau_s`` after its estimate."""
    center: FloatArray = np.asarray(center_m, dtype=np.float64) + tau_s * np.asarray(
        v_m_s, dtype=np.float64
    )
    cov: FloatArray = np.asarray(cov_m2, dtype=np.float64) + (sigma_v_m_s * tau_s) ** 2 * np.eye(3)
    return center, cov


def state_value(goal_terms: ArrayLike, hazard_terms: ArrayLike) -> FloatArray:
    """Eq. (2) along the last axis: best goal term plus worst (most negative) hazard term.

    ``goal_terms : (..., G)`` with G >= 1 values of eq. (1) with R > 0, ``hazard_terms :
    (..., H)`` with R < 0 (H may be 0: no hazard). Gated-out hazards are 0 and so never "worst"
    unless every hazard is gated out.
    """
    goals = np.asarray(goal_terms, dtype=np.float64)
    hazards = np.asarray(hazard_terms, dtype=np.float64)
    worst = (
        np.minimum(hazards.min(axis=-1), 0.0)
        if hazards.shape[-1] > 0
        else np.zeros(hazards.shape[:-1])
    )
    value: FloatArray = goals.max(axis=-1) + worst
    return value
