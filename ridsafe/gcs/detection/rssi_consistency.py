r"""Spoofing detectors on RSSI: does a claimed position agree with the physics of the radio?

Every reception i of a transmission claimed at c, heard at r_i with RSSI z_i, implies a
transmit power (paper eq. (8), d in metres)::

    y_i = z_i + 20 log10(max(d_i, 1)) + L,      d_i = ||c - r_i||

Honest transmitter: y_i = Pt + e_i, the same unknown Pt for every reception, e_i ~ N(0, s_i^2),
s_i^2 = s^2 + (20/ln10 * sigma_pos / d_i)^2 (RSSI noise plus the claimed / reported position
error seen in dB; sigma_pos = 0 gives the paper's model). Weights w_i = 1 / s_i^2.

A liar at p = c - delta: y_i = Pt + g_i^T delta + O(delta^2), g_i = (20/ln10)(c - r_i) / d_i^2.

Detectors (each reports a statistic and a decision per transmission):

- NIS (the paper's, Bjorkman et al.): one scalar Kalman filter per (receiver, claimed
  transmitter) on y, F = H = 1, Q = 0.01, R = 4 (+ the position term above), P0 = 10, started
  at the first y. NIS = nu^2 / (P^- + R); statistic = the largest NIS of the transmission;
  alert over chi2_1 99 % = 6.63. A constant lie is absorbed into the power estimate.
- POWER_SPREAD: one transmission, Pt^ = sum w y / sum w, T = sum w (y - Pt^)^2 ~ chi2_{k-1}.
- NIS_WINDOW: the same over every reception of the last ``window_s`` seconds with one shared
  power (it is constant per transmitter): T ~ chi2_{n-1}.
- MLAT: the multilateration check as a score (Rao) test of a constant position offset over
  the window. With G~ = G - 1 g^T (g = weighted mean of the rows g_i), b = G~^T W (y - Pt^)
  and A = G~^T W G~, T = b^T A^+ b ~ chi2_rank(A) *exactly* under H0 (the null model is linear
  in Pt and A does not depend on the data). delta^ = A^+ b is one Gauss-Newton step from
  the claim: T is the Mahalanobis distance squared between the estimated and the claimed
  position, so this is "estimated vs claimed position" with an honest covariance A^-1.
- CUSUM (Page 1954): on z_j = Phi^-1(1 - p_j), p_j the single-transmission MLAT p-value
  (N(0, 1) under H0 for any degrees of freedom): g_j = max(0, g_{j-1} + z_j - drift).
- MLAT_LONG (with ``long_window_s`` > 0): MLAT over the last ``long_window_s`` seconds. A
  constant lie's evidence grows with the time it is heard; a separate detector, so a
  calibrating GCS learns its null apart from the short window's (``calibration/review.py``).

Statistics of the chi-square tests with varying degrees of freedom (POWER_SPREAD,
NIS_WINDOW, MLAT, MLAT_LONG) are reported as surprisal -log10(p-value) against
-log10(p_false_alarm), so one threshold sweep draws a ROC curve. All window statistics come
from per-transmission sufficient statistics kept in a ring (sums of w, w y, w y^2, w g,
w g y, w g g^T), so a window costs one array sum.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtrc, ndtri

from ridsafe.common.messages import RidsafeDetector
from ridsafe.common.pathloss import DB_PER_LN
from ridsafe.gcs.detection.rssi_consistency_kernels import observe_batch_kernel, observe_params
from ridsafe.gcs.detection.rssi_state import RING, RssiStatePool
from ridsafe.gcs.pipeline_api import (
    DetectorResult,
    ObservedClaim,
    claimed_positions,
    reception_bounds,
)
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig

FloatArray = NDArray[np.float64]

__all__ = [
    "ImpliedPowers",
    "PairNis",
    "RssiConsistencyDetectors",
    "implied_powers",
    "offset_score_test",
    "spread_test",
    "sufficient_statistics",
    "surprisal",
]

# Layout of one row of sufficient statistics.
_N, _SW, _SWY, _SWYY = 0, 1, 2, 3
_SWG = slice(4, 7)
_SWGY = slice(7, 10)
_SWGG = slice(10, 19)
ROW = 19
_MAX_SURPRISAL = 300.0
_RANK_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class ImpliedPowers:
    """Per reception: implied power ``y`` (dBm), weight ``w`` (1/dB^2), offset gradient ``g``
    ((k, 3), dB per metre of delta), distance to the claim ``d_m``."""

    y: FloatArray
    w: FloatArray
    g: FloatArray
    d_m: FloatArray


def implied_powers(
    claimed: FloatArray, rx: FloatArray, rssi: FloatArray, sigma_db: float, cfg: DetectionConfig
) -> ImpliedPowers:
    """y_i, w_i and g_i of one transmission (module docstring)."""
    diff = claimed - rx
    d2 = np.maximum(np.sum(diff * diff, axis=1), 1.0)
    y = rssi + 10.0 * np.log10(d2) + cfg.loss_at_1m_db
    var = sigma_db**2 + (DB_PER_LN * cfg.position_sigma_m) ** 2 / d2
    g = DB_PER_LN * diff / d2[:, None]
    return ImpliedPowers(y, 1.0 / var, g, np.sqrt(d2))


def sufficient_statistics(ip: ImpliedPowers, y_ref: float) -> FloatArray:
    """One row: n, sum w, sum w y, sum w y^2, sum w g, sum w g y, sum w g g^T (y - y_ref)."""
    yc = ip.y - y_ref
    wg = ip.g * ip.w[:, None]
    row = np.empty(ROW)
    row[_N] = ip.y.shape[0]
    row[_SW] = ip.w.sum()
    row[_SWY] = ip.w @ yc
    row[_SWYY] = ip.w @ (yc * yc)
    row[_SWG] = wg.sum(axis=0)
    row[_SWGY] = yc @ wg
    row[_SWGG] = (wg.T @ ip.g).ravel()
    return row


def spread_test(s: FloatArray) -> tuple[float, int]:
    """(T, dof): T = sum w (y - Pt^)^2 ~ chi2_{n-1} from a row of sums."""
    rss = s[_SWYY] - s[_SWY] ** 2 / s[_SW]
    return max(float(rss), 0.0), int(s[_N]) - 1


def offset_score_test(s: FloatArray) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Score tests of a constant offset from rows of sums ``s : (B, ROW)``:
    (T (B,), rank (B,), delta^ (B, 3))."""
    pt = s[:, _SWY] / s[:, _SW]
    swg = s[:, _SWG]
    b = s[:, _SWGY] - swg * pt[:, None]
    A = s[:, _SWGG].reshape(-1, 3, 3) - swg[:, :, None] * swg[:, None, :] / s[:, _SW, None, None]
    lam, V = np.linalg.eigh(0.5 * (A + np.swapaxes(A, 1, 2)))
    keep = lam > _RANK_TOL * np.maximum(lam[:, -1:], 1e-300)
    proj = np.einsum("bij,bi->bj", V, b)  # V^T b
    coef = np.where(keep, proj / np.where(keep, lam, 1.0), 0.0)
    T = np.sum(proj * coef, axis=1)
    delta = np.einsum("bij,bj->bi", V, coef)
    return T, keep.sum(axis=1), delta


def surprisal(statistic: float, dof: int) -> float:
    """-log10 P(chi2_dof > statistic), capped at 300."""
    return _surprisal(float(chdtrc(dof, statistic)), dof) if dof > 0 else 0.0


def probit(statistic: float, dof: int) -> float:
    """Phi^-1(1 - p), p = P(chi2_dof > statistic): N(0, 1) under H0."""
    return _probit(float(chdtrc(dof, statistic)), dof) if dof > 0 else 0.0


def _surprisal(p_value: float, dof: int) -> float:
    """``surprisal`` from the p-value (chdtrc over several tests is one call)."""
    if dof <= 0:
        return 0.0
    p = float(p_value)
    return _MAX_SURPRISAL if p <= 0.0 else min(-math.log10(p), _MAX_SURPRISAL)


def _probit(p_value: float, dof: int) -> float:
    """``probit`` from the p-value."""
    if dof <= 0:
        return 0.0
    return float(-ndtri(max(float(p_value), 1e-300)))


class PairNis:
    """The paper's per-(receiver, transmitter) scalar Kalman filters for one transmitter, one
    slot per MAVLink system id (0..255; 4 kB per transmitter)."""

    SLOTS = 256

    def __init__(self, cfg: DetectionConfig) -> None:
        self.cfg = cfg
        self.x = np.zeros(self.SLOTS)  # power estimate per receiver (dBm)
        self.P = np.zeros(self.SLOTS)  # its variance (dB^2)
        self.started = np.zeros(self.SLOTS, dtype=bool)

    @staticmethod
    def slots(rx_sysid: NDArray[np.int64]) -> NDArray[np.int64]:
        """Each receiver's slot in ``x``, ``P``, ``started``: its system id."""
        out: NDArray[np.int64] = np.asarray(rx_sysid, dtype=np.int64) & 0xFF
        return out

    def step(self, rx_sysid: NDArray[np.int64], ip: ImpliedPowers) -> float:
        """Update every pair with its reception; the largest NIS among started pairs."""
        cfg = self.cfg
        idx = self.slots(rx_sysid)
        started = self.started[idx]
        x, P = self.x[idx], self.P[idx] + cfg.nis_q_db2
        R = cfg.nis_r_db2 + (DB_PER_LN * cfg.position_sigma_m / ip.d_m) ** 2
        nu = ip.y - x
        S = P + R
        nis = np.where(started, nu * nu / S, 0.0)
        K = P / S
        self.x[idx] = np.where(started, x + K * nu, ip.y)
        self.P[idx] = np.where(started, (1.0 - K) * P, cfg.nis_p0_db2)
        self.started[idx] = True
        return float(nis.max()) if nis.shape[0] else 0.0


class RssiConsistencyDetectors:
    """The detectors above for one claimed transmitter (benign or not), run together by
    one compiled kernel (``rssi_consistency_kernels.observe_kernel``) on every claim heard
    by at least ``min_receivers``. The memory lives in a row of a ``RssiStatePool`` (by
    default the process's ``SHARED_POOL``), so ``observe_batch`` runs the claims of many
    transmitters through one call.

    The window keeps at most ``RING`` claims (64: a transmitter broadcasting faster than
    6 Hz sees its window shortened to the latest 64).
    """

    #: What this bank reports, in the order of ``observe``'s results; then MLAT_LONG when
    #: ``long_window_s`` > 0.
    DETECTORS = (
        RidsafeDetector.NIS,
        RidsafeDetector.POWER_SPREAD,
        RidsafeDetector.NIS_WINDOW,
        RidsafeDetector.CUSUM,
        RidsafeDetector.MLAT,
    )

    RING = RING

    def __init__(
        self, uas_id: str, cfg: DetectionConfig, sigma_db: float, pool: RssiStatePool | None = None
    ) -> None:
        self.uas_id = uas_id
        self.cfg = cfg
        self.sigma_db = sigma_db
        self.cusum = 0.0
        self._y_ref: float | None = None
        self._thr = -math.log10(cfg.p_false_alarm)
        params = observe_params(
            cfg.window_s,
            sigma_db**2,
            (DB_PER_LN * cfg.position_sigma_m) ** 2,
            cfg.loss_at_1m_db,
            cfg.nis_q_db2,
            cfg.nis_r_db2,
            cfg.nis_p0_db2,
            cfg.long_window_s,
        )
        self.pool = SHARED_POOL if pool is None else pool
        self.row = self.pool.acquire(params)
        weakref.finalize(self, self.pool.release, self.row)
        self.last_offset_enu_m = np.zeros(3)  # the MLAT window's delta^ (claimed - estimated)

    @classmethod
    def for_transmitter(cls, uas_id: str, cfg: PipelineConfig) -> RssiConsistencyDetectors:
        """The bank of one claimed transmitter (its registry entry: ``detection/registry.py``)."""
        return cls(uas_id, cfg.detection, cfg.rssi_sigma_db)

    def observe(self, claim: ObservedClaim) -> tuple[DetectorResult, ...]:
        """Run every detector on one claim (needs ``min_receivers``)."""
        return self.observe_batch([self], [claim])[0]

    @staticmethod
    def observe_batch(
        banks: Sequence[RssiConsistencyDetectors], claims: Sequence[ObservedClaim]
    ) -> list[tuple[DetectorResult, ...]]:
        """``banks[j].observe(claims[j])`` for every j in order (a bank may come more than
        once), in one kernel call when the banks share a pool: the same arithmetic."""
        out: list[tuple[DetectorResult, ...]] = [()] * len(claims)
        todo = [j for j, c in enumerate(claims) if c.n_receivers >= banks[j].cfg.min_receivers]
        if not todo:
            return out
        pool = banks[todo[0]].pool
        if any(banks[j].pool is not pool for j in todo):  # banks of separate pools
            for j in todo:
                out[j] = banks[j].observe(claims[j])
            return out
        for j in todo:
            banks[j]._start_reference(claims[j])
        stats, dofs, deltas = _run_kernel(
            pool, [banks[j].row for j in todo], [claims[j] for j in todo]
        )
        p = chdtrc(dofs[:, _P_DOF], stats[:, _P_STAT])
        # ``probit`` of the single-claim offset test (CUSUM's input), elementwise at once
        z = np.where(dofs[:, 2] > 0, -ndtri(np.maximum(p[:, 3], 1e-300)), 0.0)
        for j, nis, dof, delta, p_j, z_j in zip(
            todo, stats[:, 0].tolist(), dofs.tolist(), deltas, p.tolist(), z.tolist(), strict=True
        ):
            out[j] = banks[j]._results(nis, dof, delta, p_j, z_j)
        return out

    def _start_reference(self, claim: ObservedClaim) -> None:
        """The implied-power reference: the median over the first claim tested."""
        if self._y_ref is None:
            ip = implied_powers(
                claim.claimed_p_enu_m, claim.rx_p_enu_m, claim.rssi_dbm, self.sigma_db, self.cfg
            )
            self._y_ref = float(np.median(ip.y))
            self.pool.y_ref[self.row] = self._y_ref

    def _results(
        self, nis: float, dof: list[int], delta: FloatArray, p: list[float], z: float
    ) -> tuple[DetectorResult, ...]:
        """One claim's results from the kernel's NIS, dofs, delta^, the p-values (spread,
        window spread, window offset, single offset, long-window offset) and the single
        offset's probit."""
        cfg, uas_id, thr = self.cfg, self.uas_id, self._thr
        dof_one, wdof, _rank_one, rank_win, rank_long = dof
        self.last_offset_enu_m = delta
        self.cusum = cusum = max(0.0, self.cusum + z - cfg.cusum_drift)
        spread = _surprisal(p[0], dof_one)
        window = _surprisal(p[1], wdof)
        mlat = _surprisal(p[2], rank_win)
        nis_thr, cusum_thr = cfg.nis_threshold, cfg.cusum_threshold
        results = (
            DetectorResult(uas_id, RidsafeDetector.NIS, nis, nis_thr, nis > nis_thr),
            DetectorResult(uas_id, RidsafeDetector.POWER_SPREAD, spread, thr, spread > thr),
            DetectorResult(uas_id, RidsafeDetector.NIS_WINDOW, window, thr, window > thr),
            DetectorResult(uas_id, RidsafeDetector.CUSUM, cusum, cusum_thr, cusum > cusum_thr),
            DetectorResult(uas_id, RidsafeDetector.MLAT, mlat, thr, mlat > thr),
        )
        if cfg.long_window_s <= 0.0:
            return results
        long = _surprisal(p[4], rank_long)
        return (*results, DetectorResult(uas_id, RidsafeDetector.MLAT_LONG, long, thr, long > thr))


#: The rows of every bank made without a pool of its own.
SHARED_POOL = RssiStatePool()
#: Columns of the kernel's (dofs, stats) behind the p-values (spread, window spread, window
#: offset, single-claim offset, long-window offset): one chdtrc call for a whole cycle.
_P_DOF = [0, 1, 3, 2, 4]
_P_STAT = [1, 2, 4, 3, 5]


def _run_kernel(
    pool: RssiStatePool, rows: list[int], claims: list[ObservedClaim]
) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """``observe_batch_kernel`` on ``claims``, claim j on pool row ``rows[j]``."""
    bounds = reception_bounds(claims)
    return observe_batch_kernel(
        claimed_positions(claims),
        np.concatenate([c.rx_p_enu_m for c in claims]),
        np.concatenate([c.rssi_dbm for c in claims]),
        np.concatenate([c.rx_sysid for c in claims]).astype(np.int64, copy=False),
        bounds,
        np.array([c.t_s for c in claims]),
        np.array(rows, dtype=np.int64),
        pool.pair_power_dbm,
        pool.pair_var_db2,
        pool.pair_started,
        pool.ring,
        pool.ring_t,
        pool.y_ref,
        pool.params,
    )
