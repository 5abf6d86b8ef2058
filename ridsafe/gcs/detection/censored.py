r"""MLAT_CENSORED: the claimed position tested on receptions that are a censored sample.

A receiver reports nothing weaker than its sensitivity. On a short-range channel (a
path-loss exponent of 3 puts 20 dBm at -95 dBm about 320 m away) a transmitter outside the
fleet is heard, in its first seconds, by a few receivers within a few dB of their cut. What
they report runs above their links' means, and near the cut a reception says less about its
mean than an uncensored one. MLAT (``rssi_consistency.py``) subtracts the expected lift and
linearises at the claim; this test takes each reception from the normal truncated at its
receiver's cut and maximises the likelihood exactly: T = 2 (max l(delta, P) - max l(0, P))
over a common offset delta and the transmit power, about chi2_3 for an honest claim
(``censored_kernels.py``), reported as surprisal against -log10 ``p_false_alarm``. On
exponent 3 at 16 aircraft, measured on logs with the receivers' biases known, it would bring
the detection delay median from 6.55 s to 5.0 s; in the GCS, on its young fit (its cut, biases
and the position term together), it alerts sooner in 5 runs of 30 (median 6.5 s;
docs/results/robustness.md, "Who did not hear it").

It runs where the calibration estimates the cut (``ObservedClaim.cut_rssi_dbm``,
``cut_floor_dbm``: the RSSI and the cut mapped onto the free-space model, the lift not
subtracted; ``calibration/pipeline.py``) and only on windows with a reception within
``censored_margin_sigma`` noise stds of its cut: elsewhere the censoring changes nothing and
the test is MLAT's. The receivers that did not hear a claim would add evidence (offline:
4.2 s); this test does not count them. Its threshold on a calibrating
GCS is the empirical null's like every detector's (``calibration/review.py``): an exact test
is as exposed as MLAT to errors the fit does not model.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.messages import RidsafeDetector
from ridsafe.common.pathloss import DB_PER_LN
from ridsafe.gcs.detection.censored_kernels import offset_glrt
from ridsafe.gcs.detection.rssi_consistency import surprisal
from ridsafe.gcs.detection.rssi_state import RING
from ridsafe.gcs.pipeline_api import DetectorResult, ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig

FloatArray = NDArray[np.float64]

__all__ = ["SEARCH_GRID_ENU_M", "CensoredLikelihoodDetector"]

#: The offset search starts at 0 and at the best points of this level grid (m): 30 m apart
#: out to 150 m.
SEARCH_GRID_ENU_M = np.array(
    [[x, y, 0.0] for x in np.arange(-150.0, 151.0, 30.0) for y in np.arange(-150.0, 151.0, 30.0)]
)
#: The mapped RSSI follows the free-space model (``calibration/pipeline.py``).
_FREE_SPACE_EXPONENT = 2.0
#: No miss enters the test; the kernel's miss floor is then unused.
_UNUSED_MISS_FLOOR = 0.5


class CensoredLikelihoodDetector:
    """One claimed transmitter's window of receptions for MLAT_CENSORED."""

    def __init__(self, uas_id: str, cfg: PipelineConfig) -> None:
        self.uas_id = uas_id
        self._window_s = cfg.detection.censored_window_s
        self._margin = cfg.detection.censored_margin_sigma
        self._min_receivers = cfg.detection.min_receivers
        self._sigma_db = cfg.rssi_sigma_db
        self._position_sigma_m = cfg.detection.position_sigma_m
        self._threshold = -math.log10(cfg.detection.p_false_alarm)
        #: (t_s, claimed minus receiver positions (k, 3), RSSI (k,), cut (k,), receivers (k,));
        #: at most the other windows' ``RING`` claims, however fast a transmitter claims
        self._claims: deque[tuple[float, FloatArray, FloatArray, FloatArray, NDArray[np.int64]]] = (
            deque(maxlen=RING)
        )

    @property
    def window_claims(self) -> int:
        """How many claims its window holds (at most ``RING``)."""
        return len(self._claims)

    @classmethod
    def for_transmitter(cls, uas_id: str, cfg: PipelineConfig) -> CensoredLikelihoodDetector | None:
        """The detector of one claimed transmitter; None with ``censored_window_s`` 0."""
        return cls(uas_id, cfg) if cfg.detection.censored_window_s > 0.0 else None

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        """The test on the window ending with ``claim``; none where no cut is known, fewer
        than ``min_receivers`` receivers heard the window (a claim heard by two is tested
        with the ones before it) or no reception of the window is near its cut."""
        rssi, floor = claim.cut_rssi_dbm, claim.cut_floor_dbm
        if rssi is None or floor is None:
            return ()
        t_s = claim.t_s
        diff = claim.claimed_p_enu_m - claim.rx_p_enu_m
        self._claims.append((t_s, diff, rssi, floor, claim.rx_sysid))
        while self._claims[0][0] <= t_s - self._window_s:
            self._claims.popleft()
        receivers = {int(r) for c in self._claims for r in c[4]}
        if len(receivers) < self._min_receivers:
            return ()
        diff = np.concatenate([c[1] for c in self._claims])
        rssi_all = np.concatenate([c[2] for c in self._claims])
        floor_all = np.concatenate([c[3] for c in self._claims])
        d2 = np.maximum(np.sum(diff * diff, axis=1), 1.0)
        sigma = np.sqrt(self._sigma_db**2 + (DB_PER_LN * self._position_sigma_m) ** 2 / d2)
        if not np.any(rssi_all - floor_all < self._margin * sigma):
            return ()
        statistic = offset_glrt(
            diff,
            np.ones(diff.shape[0], dtype=np.bool_),
            rssi_all,
            floor_all,
            _FREE_SPACE_EXPONENT,
            sigma,
            _UNUSED_MISS_FLOOR,
            False,
            SEARCH_GRID_ENU_M,
        )
        s = surprisal(statistic, 3)
        return (
            DetectorResult(
                self.uas_id, RidsafeDetector.MLAT_CENSORED, s, self._threshold, s > self._threshold
            ),
        )
