r"""Ellipsoid containment: the one reference for "is this point inside that region".

An unsafe region (paper eq. (10)) is the ellipsoid of centre c, covariance P and threshold
chi2 = F^-1_{chi2_3}(1 - alpha)::

    m(x) = (x - c)^T P^-1 (x - c),        x inside  <=>  m(x) <= chi2

The GCS makes regions, every companion keeps clear of them, the run metrics score them
(containment of the spoofer, benign aircraft entering one), and the synthetic evaluation of
the GCS counts containment: all use :func:`mahalanobis2` and :func:`inside` from here.
Compiled (numba) kernels that need the same quantity inside a loop keep a twin beside their
kernel (``gcs/localisation/mixture_kernels.py``); the tests compare each twin with this one.

The squared distance is computed from the eigen-decomposition P = V diag(lambda) V^T::

    y = V^T d,     m = sum_k y_k^2 / lambda_k        (a term with y_k = 0 counts 0)

so a singular P gives a finite m on its support and inf off it instead of failing, and a
point at the centre of any covariance gives 0. Shapes broadcast: ``d : (..., 3)`` with
``cov : (..., 3, 3)``; the result has the broadcast leading shape.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["inside", "mahalanobis2"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def mahalanobis2(d: ArrayLike, cov: ArrayLike) -> FloatArray:
    """``d^T P^-1 d`` for offsets ``d : (..., 3)`` from the centre and ``P : (..., 3, 3)``
    (symmetric), broadcast; inf off the support of a singular P."""
    eigenvalues, vectors = np.linalg.eigh(np.asarray(cov, dtype=np.float64))
    y = np.einsum("...ji,...j->...i", vectors, np.asarray(d, dtype=np.float64))
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(y == 0.0, 0.0, y**2 / np.where(eigenvalues > 0.0, eigenvalues, 0.0))
    return np.asarray(terms.sum(axis=-1), dtype=np.float64)


def inside(
    point_m: ArrayLike, center_m: ArrayLike, cov_m2: ArrayLike, chi2_threshold: ArrayLike
) -> BoolArray:
    """``m(point) <= chi2_threshold``: points ``(..., 3)`` inside ellipsoids of centre
    ``(..., 3)``, covariance ``(..., 3, 3)`` and threshold ``(...)``, broadcast. A NaN point
    is never inside."""
    d = np.asarray(point_m, dtype=np.float64) - np.asarray(center_m, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        result: BoolArray = mahalanobis2(d, cov_m2) <= np.asarray(chi2_threshold)
    return result
