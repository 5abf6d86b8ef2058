r"""Receptions near the receivers' sensitivity: what survives the cut runs above the mean.

A receiver reports nothing weaker than its sensitivity ``c``. On a link whose mean RSSI
``mu`` lies near ``c``, only the receptions the noise lifted above it are reported, so what
is reported runs above the mean by the mean of a normal truncated at ``c``::

    E[rssi | rssi >= c] = mu + sigma lambda(alpha),    alpha = (c - mu) / sigma,
    lambda(alpha) = phi(alpha) / (1 - Phi(alpha))      (the inverse Mills ratio)

(Johnson, Kotz & Balakrishnan, *Continuous Univariate Distributions* 1, 2nd ed., 1994,
sec. 13.10.1). The lift vanishes on links well above the cut (alpha = -3: 0.004 sigma) and
grows to ``c - mu`` on links below it. Left alone it biases the fit (far links taken for
stronger than they are: an exponent of 3 fitted as 2.95) and reads, in a window test of a
transmitter heard mostly near the cut (one at the edge of the fleet), as a lie about its
position that grows with distance: with an exponent of 3 and -95 dBm receivers a quarter of
the fleet's receptions lie within 3 dB of the cut, and an honest stranger there was alerted
in 4-6 runs of 30.

The correction subtracts the expected lift instead of dropping the links near the cut (the
early links near the cut are the early evidence, and on a noisy channel the cut's margin
would cover most of them):

* the fit (``channel_fit.fit_channel`` with a floor): fitted again on ``rssi - sigma
  lambda`` with the lift taken at the previous pass's fitted means (``CENSORING_PASSES``
  times); the fixed point solves the truncated normal's likelihood equation
  sum_k x_k (rssi_k - mu_k - sigma lambda_k) = 0;
* the detectors (``lift_at_claims``): each claim's receptions less the lift their link
  would have were the claim true, the transmitter's level the median of its receptions'
  implied levels at the claimed position (taken twice, the second time on the corrected
  RSSI): a test of the claim, the same rule for the fleet's claims and a stranger's, so the
  empirical null stays comparable (``review.py``). The tracks keep the plain fit and the
  RSSI as received: a liar's claimed position says nothing of its links.

The GCS is not told the sensitivity. ``SensitivityFloor`` takes the weakest RSSI any
receiver has reported: with a cut, receptions pile up just above it; without one it is a
fade 2-4 sigma below the weakest links' means, and the lifts it implies are negligible
(``NEGLIGIBLE_LIFT_SIGMA``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.special import log_ndtr

from ridsafe.gcs.pipeline_api import ObservedClaim, reception_bounds

FloatArray = NDArray[np.float64]

__all__ = [
    "MAX_ALPHA",
    "NEGLIGIBLE_LIFT_SIGMA",
    "SensitivityFloor",
    "claim_medians",
    "expected_lift_db",
    "lift_at_claims",
    "significant_lift_db",
]

#: Links predicted more than this many sigma below the cut are taken at this many: their
#: receptions carry almost nothing of their mean, and the fit's passes converge slowly there.
MAX_ALPHA = 4.0
#: A lift under this fraction of sigma is not corrected (links 1.7 sigma or more above the
#: cut): a window test of 600 receptions all lifted by 0.1 sigma would gain 6 in its
#: chi-square, whose std is 35. Where the cut binds on no link the RSSI stays as it came
#: (without a cut the weakest RSSI is a fade 2-4 sigma below the weakest links' means).
NEGLIGIBLE_LIFT_SIGMA = 0.1
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


class SensitivityFloor:
    """The weakest RSSI any receiver reported so far (dBm; ``-inf`` before any): the
    receivers' sensitivity as far as the GCS can tell (module docstring)."""

    def __init__(self) -> None:
        self._weakest_dbm = math.inf

    @property
    def dbm(self) -> float:
        return -math.inf if self._weakest_dbm == math.inf else self._weakest_dbm

    def observe(self, claims: Sequence[ObservedClaim]) -> None:
        """Take the weakest RSSI of each claim whose weakest is finite (a claim holding a
        NaN or an infinity teaches nothing), all claims in one pass."""
        heard = [claim for claim in claims if claim.n_receivers]
        if not heard:
            return
        starts = reception_bounds(heard)[:-1]
        rssi = np.concatenate([claim.rssi_dbm for claim in heard])
        weakest = np.minimum.reduceat(rssi, starts)  # NaN stays NaN
        weakest = weakest[np.isfinite(weakest)]
        if weakest.shape[0]:
            self._weakest_dbm = min(self._weakest_dbm, float(weakest.min()))


def expected_lift_db(mean_dbm: FloatArray, floor_dbm: float, sigma_db: float) -> FloatArray:
    """``(k,)`` sigma lambda((floor - mean) / sigma): how far above its mean ``mean_dbm`` a
    link's reported RSSI runs when nothing below ``floor_dbm`` is reported (module
    docstring); 0 without a floor."""
    if not math.isfinite(floor_dbm) or sigma_db <= 0.0:
        return np.zeros_like(mean_dbm)
    alpha = np.minimum((floor_dbm - mean_dbm) / sigma_db, MAX_ALPHA)
    log_pdf = -0.5 * alpha * alpha - _LOG_SQRT_2PI
    lift: FloatArray = sigma_db * np.exp(log_pdf - log_ndtr(-alpha))
    return lift


def significant_lift_db(mean_dbm: FloatArray, floor_dbm: float, sigma_db: float) -> FloatArray:
    """``expected_lift_db`` where it is at least ``NEGLIGIBLE_LIFT_SIGMA`` sigma, else 0."""
    lift = expected_lift_db(mean_dbm, floor_dbm, sigma_db)
    out: FloatArray = np.where(lift >= NEGLIGIBLE_LIFT_SIGMA * sigma_db, lift, 0.0)
    return out


def lift_at_claims(
    rssi_dbm: FloatArray,
    bounds: NDArray[np.int64],
    loss_db: FloatArray,
    bias_db: FloatArray,
    floor_dbm: float,
    sigma_db: float,
) -> FloatArray:
    """Every reception's expected lift (dB, in order; 0 where negligible) were its claim
    true: ``rssi_dbm``, ``loss_db`` and ``bias_db`` ``(k,)`` (the fitted path loss from the
    claimed position, antenna gain included, and the receiver's bias), claim j's rows
    ``bounds[j]:bounds[j + 1]``; the claim's level the median implied level, taken twice
    (module docstring)."""
    if not math.isfinite(floor_dbm):
        return np.zeros_like(rssi_dbm)
    implied = rssi_dbm - bias_db + loss_db
    level = claim_medians(implied, bounds)
    first = significant_lift_db(level + bias_db - loss_db, floor_dbm, sigma_db)
    level = claim_medians(implied - first, bounds)
    return significant_lift_db(level + bias_db - loss_db, floor_dbm, sigma_db)


def claim_medians(values: FloatArray, bounds: NDArray[np.int64]) -> FloatArray:
    """``(k,)``: each reception's claim's median of ``values`` (claim j's rows
    ``bounds[j]:bounds[j + 1]``), every claim in one sort."""
    counts = np.diff(bounds)
    claim_of = np.repeat(np.arange(counts.shape[0]), counts)
    padded = np.full((counts.shape[0], max(int(counts.max(initial=0)), 1)), np.inf)
    padded[claim_of, np.arange(values.shape[0]) - bounds[claim_of]] = values
    padded.sort(axis=1)
    rows = np.arange(counts.shape[0])
    low, high = np.maximum(counts - 1, 0) // 2, counts // 2
    medians: FloatArray = 0.5 * (padded[rows, low] + padded[rows, high])
    return medians[claim_of]
