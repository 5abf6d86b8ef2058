"""The planner kernel's geometry of one point against one (already predicted) unsafe region:
eq. 4 of :mod:`ridsafe.companion.value` before its clamp, and the depth inside the region's
horizontal marginal (``value.region_intrusion_m`` is the numpy statement of both)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit_inline

__all__ = ["horizontal_depth", "region_signed_distance"]

FloatArray = NDArray[np.float64]


@jit_inline
def region_signed_distance(
    x: float, y: float, z: float, c: FloatArray, pinv: FloatArray, sigma: float, sqrt_chi2: float
) -> float:
    """Value eq. 4 for one point against one (already predicted) region, before its clamp at
    0: negative inside the ellipsoid."""
    dx, dy, dz = x - c[0], y - c[1], z - c[2]
    m = (
        pinv[0, 0] * dx * dx
        + pinv[1, 1] * dy * dy
        + pinv[2, 2] * dz * dz
        + 2.0 * (pinv[0, 1] * dx * dy + pinv[0, 2] * dx * dz + pinv[1, 2] * dy * dz)
    )
    return sigma * (math.sqrt(max(m, 0.0)) - sqrt_chi2)


@jit_inline
def horizontal_depth(
    x: float, y: float, c: FloatArray, pinv: FloatArray, sigma: float, sqrt_chi2: float
) -> float:
    """sigma (sqrt(chi2) - sqrt(m_h)), >= 0: how deep (x, y) lies in the region's horizontal
    marginal, whose precision is the Schur complement of P^-1's vertical entry."""
    dx, dy = x - c[0], y - c[1]
    a = pinv[0, 0] - pinv[0, 2] * pinv[2, 0] / pinv[2, 2]
    b = pinv[0, 1] - pinv[0, 2] * pinv[2, 1] / pinv[2, 2]
    e = pinv[1, 1] - pinv[1, 2] * pinv[2, 1] / pinv[2, 2]
    m_h = a * dx * dx + 2.0 * b * dx * dy + e * dy * dy
    return sigma * max(0.0, sqrt_chi2 - math.sqrt(max(m_h, 0.0)))
