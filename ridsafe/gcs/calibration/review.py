r"""The alert decision on a channel the detectors model imperfectly: a cooperative cross-check
and an empirical null learnt from the cooperative aircraft.

The detectors' thresholds (``detection/rssi_consistency.py``) hold when the RSSI follows the
model they assume: i.i.d. Gaussian noise of the fitted sigma around a log-distance loss.
A real channel (ground reflection, antenna patterns, correlated shadowing, fading) leaves
errors that are heavy-tailed and correlated over a window, and every window test then
counts the same error many times: on ``configs/urban.yaml`` the cooperative aircraft's own
MLAT statistics reached 11 times the threshold. Two facts of the fleet fix the decision:

1. **Cross-check.** A claim of a serial labelled cooperative (``cooperative.py``) that lies
   within ``vouch_m`` of where that aircraft itself last reported being is the aircraft
   telling the truth: it raises no alert (``cooperative_veto``).
2. **Empirical null.** The cooperative aircraft's claims are honest, so their detector
   statistics are draws from each detector's null distribution *on this channel*. For
   detector D, with S_D(t) the largest statistic of any vouched claim over the last
   ``null_window_s``, an unvouched claim's decision is::

       statistic > max(threshold, null_margin * S_D(t))

   With N cooperative transmitters heard over the window, an honest stranger exchangeable
   with them exceeds S_D with probability about 1 / (N * claims per window) per claim
   (Efron's empirical null, JASA 99(465), 2004, used at its extreme quantile), and the
   margin keeps that rare. On the model the detectors assume S_D stays below the threshold
   and nothing changes; on a channel they model badly the threshold rises with the errors.

Until ``null_min_claims`` vouched claims were seen no unvouched claim alerts (the null is not
known yet).

3. **Honest localisation covariance.** The vouched claims' MLAT statistic is the squared
   Mahalanobis distance between the window's position estimate and the true position,
   with the covariance the i.i.d. model promises: chi2_3 when the model holds. Errors that
   repeat over the window inflate it by the factor c by which that covariance is
   overconfident; ``localisation_inflation`` = median(T) / median(chi2_3), at least 1,
   is what the localisers' noise variance is multiplied by (``PipelineConfig.
   localisation_noise_inflation``, set by ``pipeline.py`` before a track starts).

Statistics and thresholds stay in the results (the logged ROC data); only the decision and
the threshold it was taken against change.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from collections import deque

from scipy.special import chdtri

from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim

__all__ = ["CalibratedReview", "SlidingMax", "SlidingMedian"]


class SlidingMedian:
    """The median of the values pushed over the last ``window_s``, kept sorted (a push or an
    expiry is one bisection; the median is read off the middle, as ``np.median`` gives it:
    the mean of the two middle values when their number is even). Times must not
    decrease; a NaN is not kept (it has no place in the order)."""

    def __init__(self, window_s: float) -> None:
        self.window_s = window_s
        self._arrivals: deque[tuple[float, float]] = deque()  # (t_s, value), oldest first
        self._sorted: list[float] = []

    def push(self, t_s: float, value: float) -> None:
        if math.isnan(value):
            return
        self._arrivals.append((t_s, value))
        bisect.insort(self._sorted, value)

    def value(self, now_s: float) -> float | None:
        """The median over ``(now_s - window_s, now_s]``; None when nothing is in it."""
        arrivals, values = self._arrivals, self._sorted
        while arrivals and arrivals[0][0] <= now_s - self.window_s:
            del values[bisect.bisect_left(values, arrivals.popleft()[1])]
        n = len(values)
        if n == 0:
            return None
        middle = n // 2
        return values[middle] if n % 2 else (values[middle - 1] + values[middle]) / 2.0


class SlidingMax:
    """The largest value pushed over the last ``window_s`` (a monotonic queue: O(1)
    amortised per push). Times must not decrease."""

    def __init__(self, window_s: float) -> None:
        self.window_s = window_s
        self._queue: deque[tuple[float, float]] = deque()  # (t_s, value), values decreasing

    def push(self, t_s: float, value: float) -> None:
        while self._queue and self._queue[-1][1] <= value:
            self._queue.pop()
        self._queue.append((t_s, value))

    def value(self, now_s: float) -> float:
        """The maximum over ``(now_s - window_s, now_s]``; 0 when nothing was pushed."""
        while self._queue and self._queue[0][0] <= now_s - self.window_s:
            self._queue.popleft()
        return self._queue[0][1] if self._queue else 0.0


def _no_alert(results: tuple[DetectorResult, ...]) -> tuple[DetectorResult, ...]:
    """``results`` with every decision false (the rest as they were)."""
    if not any(r.decision for r in results):
        return results
    return tuple(dataclasses.replace(r, decision=False) if r.decision else r for r in results)


#: The median of chi2 with 3 degrees of freedom.
_CHI2_3_MEDIAN = float(chdtri(3, 0.5))


class CalibratedReview:
    """The ``EstimationPipeline`` review (``pipeline.ResultReview``): vouched claims feed the
    empirical null and raise nothing; the others are decided against it (module docstring)."""

    def __init__(self, cfg: CalibrationConfig, labeller: CooperativeLabeller) -> None:
        self.cfg = cfg
        self.labeller = labeller
        self._null: dict[RidsafeDetector, SlidingMax] = {}
        self._newest_s = float("-inf")
        self._vouched = 0
        self._mlat = SlidingMedian(cfg.null_window_s)  # the vouched claims' MLAT surprisal

    def __call__(
        self, claim: ObservedClaim, results: tuple[DetectorResult, ...]
    ) -> tuple[DetectorResult, ...]:
        t_s = self._newest_s = max(self._newest_s, claim.t_s)
        if self.labeller.vouches(claim):
            self._vouched += 1
            for r in results:
                if self.cfg.empirical_null:
                    self._null_of(r.detector).push(t_s, r.statistic)
                if self.cfg.honest_covariance and r.detector is RidsafeDetector.MLAT:
                    self._mlat.push(t_s, r.statistic)
            return _no_alert(results) if self.cfg.cooperative_veto else results
        if not self.cfg.empirical_null:
            return results
        if self._vouched < self.cfg.null_min_claims:
            return _no_alert(results)
        return tuple(self._decide(r, t_s) for r in results)

    def localisation_inflation(self, now_s: float) -> float:
        """c = median(T) / median(chi2_3) of the vouched claims' MLAT statistics over the
        window (T from the surprisal, rank 3 assumed), at least 1; 1 before any."""
        median = self._mlat.value(now_s)
        if median is None:
            return 1.0
        surprisal = float(median)
        statistic = float(chdtri(3, 10.0 ** (-min(surprisal, 300.0))))
        return max(1.0, statistic / _CHI2_3_MEDIAN)

    def null_statistic(self, detector: RidsafeDetector, now_s: float) -> float:
        """S_D: the largest statistic of a vouched claim over the window before ``now_s``."""
        return self._null_of(detector).value(now_s)

    def _decide(self, r: DetectorResult, t_s: float) -> DetectorResult:
        threshold = max(r.threshold, self.cfg.null_margin * self.null_statistic(r.detector, t_s))
        if threshold == r.threshold:
            return r
        return dataclasses.replace(r, threshold=threshold, decision=r.statistic > threshold)

    def _null_of(self, detector: RidsafeDetector) -> SlidingMax:
        null = self._null.get(detector)
        if null is None:
            null = self._null[detector] = SlidingMax(self.cfg.null_window_s)
        return null
