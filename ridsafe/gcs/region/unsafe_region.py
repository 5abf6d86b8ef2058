r"""The chance-constrained unsafe region around a spoofer estimate (paper sec. 5.1).

Given the position estimate x^ and covariance P (3 x 3, ENU) and a risk level alpha, the
unsafe region is the ellipsoid (paper eq. (10), its complement being the safe set)::

    (x - x^)^T P^-1 (x - x^) <= F^-1_{chi2_3}(1 - alpha)          (= 7.815 at alpha = 0.05)

If x ~ N(x^, P), the left side is chi2_3, so the region holds the spoofer with probability
1 - alpha (paper eq. (11)) - the containment a consistent estimator must show. Whether a
point is inside is ``ridsafe.common.ellipsoid.inside`` (one reference for the GCS, the
companions and the metrics).

Geometry, for logging and Foxglove: with P = V diag(lambda) V^T (lambda descending, V a
rotation, det V = +1), the semi-axes are sqrt(threshold * lambda_k) along the columns of V.
The largest is DESIGN.md's "ellipsoid radius".
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtri

from ridsafe.gcs.pipeline_api import UnsafeRegion, readonly
from ridsafe.gcs.pipeline_config import RegionConfig

FloatArray = NDArray[np.float64]

__all__ = [
    "chi2_threshold",
    "ellipsoid_axes",
    "make_region",
    "positive_definite",
]

#: Smallest variance (m^2) a region's covariance may have along any axis.
MIN_VARIANCE_M2 = 1e-6


@functools.lru_cache(maxsize=64)
def chi2_threshold(alpha: float, dof: int = 3) -> float:
    """F^-1_{chi2_dof}(1 - alpha): the inverse survival function at alpha (cached: a region
    is made every cycle for every track, always at the configured alpha)."""
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    return float(chdtri(dof, alpha))


def positive_definite(cov: FloatArray, floor: float = MIN_VARIANCE_M2) -> FloatArray:
    """Symmetrised ``cov`` with eigenvalues raised to at least ``floor``."""
    return _positive_definite_eigh(cov, floor)[0]


def _positive_definite_eigh(
    cov: FloatArray, floor: float = MIN_VARIANCE_M2
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(``positive_definite(cov)``, and its eigenvalues (ascending) and eigenvectors): one
    decomposition unless the floor had to be applied."""
    sym = 0.5 * (cov + cov.T)
    lam, V = np.linalg.eigh(sym)
    if lam[0] >= floor:
        return sym, lam, V
    out: FloatArray = (V * np.maximum(lam, floor)) @ V.T
    out = 0.5 * (out + out.T)
    lam, V = np.linalg.eigh(out)
    return out, lam, V


def ellipsoid_axes(cov: FloatArray, threshold: float) -> tuple[FloatArray, FloatArray]:
    """(semi_axes_m (3,) largest first, axes (3, 3) unit columns forming a rotation)."""
    lam, V = np.linalg.eigh(0.5 * (cov + cov.T))
    return _axes(lam, V, threshold)


def _axes(lam: FloatArray, V: FloatArray, threshold: float) -> tuple[FloatArray, FloatArray]:
    """``ellipsoid_axes`` from the eigen-decomposition (ascending) of the symmetric cov."""
    lam, V = np.maximum(lam[::-1], 0.0), V[:, ::-1].copy()
    if _det3(V) < 0.0:
        V[:, 2] = -V[:, 2]
    return np.sqrt(threshold * lam), V


def _det3(M: FloatArray) -> float:
    """det of a 3 x 3 matrix by cofactors (here +-1: only its sign matters)."""
    (a, b, c), (d, e, f), (g, h, i) = M.tolist()
    return float(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g))


def make_region(
    uas_id: str,
    track_id: int,
    t_s: float,
    center_enu_m: FloatArray,
    cov_enu_m2: FloatArray,
    v_enu_m_s: FloatArray,
    cfg: RegionConfig,
    on_ground: bool = False,
    unconfirmed: bool = False,
) -> UnsafeRegion:
    """The region of an estimate at ``t_s``, valid for ``cfg.validity_s``."""
    cov, lam, V = _positive_definite_eigh(cov_enu_m2)
    threshold = chi2_threshold(cfg.alpha)
    semi, axes = _axes(lam, V, threshold)
    return UnsafeRegion(
        uas_id=uas_id,
        track_id=track_id,
        t_s=t_s,
        center_enu_m=readonly(center_enu_m),
        cov_enu_m2=readonly(cov),
        v_enu_m_s=readonly(v_enu_m_s),
        chi2_threshold=threshold,
        alpha=cfg.alpha,
        valid_until_s=t_s + cfg.validity_s,
        semi_axes_m=readonly(semi),
        axes_enu=readonly(axes),
        on_ground=on_ground,
        unconfirmed=unconfirmed,
    )
