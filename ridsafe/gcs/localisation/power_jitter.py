r"""Transmit power as a per-message nuisance: an estimate of how much a transmitter's power
changes from one message to the next, for ``rssi_filter.tx_power_jitter: adaptive``.

The RSSI filter carries the transmit power Pt as a slow random walk: right for a radio at one
power (the paper's spoofer, every benign aircraft), badly wrong for one that draws a new power
for every message: a common offset b_k ~ N(0, J^2) on all receptions of message k, which the
filter then reads as range. The evidence is the common-mode innovation of each message at the
prior (mixture mean u = (p, Pt), covariance C)::

    e_k = mean_i (z_i - h_i(u)),     Var e_k = a C a^T + s^2 / n + J^2,    a = mean_i dh_i/du

so q_k = e_k^2 - a C a^T - s^2 / n estimates J^2; ``PowerJitter`` keeps an exponentially
weighted mean of q_k (weight ``forgetting`` on the newest) and reports J^2 once that mean
exceeds ``threshold_db``^2 (so a constant-power transmitter's noise does not loosen its track).
The filter then adds J^2 to the power's variance before each message's update: the power is
re-estimated from that message's receptions (their common level) and only the differences
between receivers locate the transmitter, which is what a per-message power leaves.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import LOSS_AT_1M_2400MHZ_DB

FloatArray = NDArray[np.float64]

__all__ = ["PowerJitter"]

_DB_PER_LN10 = 10.0 / math.log(10.0)


class PowerJitter:
    """The running estimate of one track's per-message power variance J^2 (dB^2)."""

    def __init__(self, forgetting: float, threshold_db: float, min_messages: int = 3) -> None:
        self.forgetting = forgetting
        self.threshold_db2 = threshold_db**2
        self.min_messages = min_messages
        self.mean_q_db2 = 0.0
        self.messages = 0

    def observe(
        self, u: FloatArray, C: FloatArray, rx: FloatArray, z: FloatArray, sigma_db: float
    ) -> None:
        """One message's receptions ``rx (k, 3)``, ``z (k,)`` at the prior ``u (4,)``, ``C``."""
        k = z.shape[0]
        if k < 2:
            return
        diff = u[:3] - rx
        d2 = np.maximum(np.sum(diff * diff, axis=1), 1.0)
        predicted = u[3] - _DB_PER_LN10 * np.log(d2) - LOSS_AT_1M_2400MHZ_DB
        e = float(np.mean(z - predicted))
        a = np.empty(4)
        a[:3] = np.mean(-2.0 * _DB_PER_LN10 * diff / d2[:, None], axis=0)
        a[3] = 1.0
        q = e * e - float(a @ C @ a) - sigma_db**2 / k
        w = 1.0 / (self.messages + 1) if self.messages < self.min_messages else self.forgetting
        self.mean_q_db2 += w * (q - self.mean_q_db2)
        self.messages += 1

    @property
    def variance_db2(self) -> float:
        """J^2 to add to the power's variance before an update (0 below the threshold)."""
        if self.messages < self.min_messages or self.mean_q_db2 < self.threshold_db2:
            return 0.0
        return self.mean_q_db2
