r"""The channel fit: log-distance path loss with per-transmitter power and per-receiver bias.

Each labelled reception k (transmitter s_k, receiver r_k, distance d_k from the receiver's
reported position to the transmitter's truthful claim) gives::

    rssi_k = P_{s_k} + b_{r_k} - 10 n log10(d_k) + e_k,        e_k ~ Student-t(nu, 0, s^2)

P_s (transmit power minus the first-metre loss, dB), b_r (receiver calibration offset, dB,
prior N(0, sigma_b^2), which also fixes the P/b gauge) and n (exponent, prior N(n0, sigma_n^2))
are fitted by iteratively reweighted least squares with the Student-t weights
w_k = (nu + 1) / (nu + r_k^2 / s^2) (Lange, Little & Taylor, JASA 84(408), 1989), the scale
s^2 = sum w r^2 / K updated each pass. The noise std reported for Gaussian consumers is the
root-mean-square residual corrected for the parameters fitted (sigma^2 = RSS / (K - p),
p = n_tx + n_rx + 1: the second moment of the heavy-tailed noise, unbiased, so covariances
and thresholds built from it stay honest; the plain RSS / K was 9 % low in std with 16
aircraft at calibration time, enough for the window tests' 600 degrees of freedom to raise
false alerts), next to the robust scale s.

Given the links' elevations e_k (|asin(dz / d)|) and ``elevation_knots_deg``, the model gains
a term g(e_k), piecewise linear between the knots with g = 0 at the first (level links carry
the levels) and each other knot's value fitted with prior N(0, sigma_g^2): the antennas'
patterns together (``pipeline.py`` says who uses which fit). A knot whose estimate is within
``elevation_gain_min_z`` of its standard errors of 0 dB is held at 0 and the fit redone: on
isotropic antennas the knots fitted a few early steep links, and their noise, applied to
every later link at that elevation, was an error the detectors' window tests saw as a lie
(the cooperative aircraft's MLAT statistic past its 1e-6 threshold in 2.5 % of claims on the
1 dB channel the GCS could have been told, 0.07 % without the elevation fit).

Given the receivers' sensitivity ``floor_dbm`` (nothing weaker is reported), the fit is
redone ``CENSORING_PASSES`` times on rssi_k - sigma lambda_k, the lift a link of the previous
pass's mean has above its mean (``censoring.py``; none where it is negligible, and no pass
where it is everywhere); its fixed point solves the truncated normal's likelihood equation,
where the plain fit takes the far links near the cut for stronger than they are (exponent 3
fitted as 2.97).

``check_configured_channel`` asks the other question first: do the labelled receptions fit
the channel the GCS was configured with (free space, Gaussian noise of ``rssi_sigma_db`` plus
the detectors' position term, a level per transmitter that the trackers estimate anyway)?
The residuals' chi-square against its own distribution decides (``calibration.enabled:
auto``, ``pipeline.py``): a channel noisier than configured, a path-loss exponent that is
not 2, receiver biases or heavy tails all raise it; a quieter channel does not, and the
configured one is then merely conservative.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtrc

from ridsafe.common.pathloss import DB_PER_LN
from ridsafe.gcs.calibration.censoring import significant_lift_db
from ridsafe.gcs.calibration.config import CalibrationConfig

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["ChannelEstimate", "ConfiguredChannelCheck", "check_configured_channel", "fit_channel"]

#: IRLS passes; from the weights of a fit to nearly the same RSSI (the censoring passes).
IRLS_PASSES = 8
WARM_IRLS_PASSES = 3
#: Fits on the RSSI less the lift the previous one expects, with a sensitivity floor.
CENSORING_PASSES = 4
#: The prior precision (1/dB^2) that holds a knot the receptions cannot resolve at 0 dB.
_PINNED_PRECISION = 1e12


@dataclass(frozen=True)
class ChannelEstimate:
    """The fitted channel; biases and powers keyed by system id (dB)."""

    exponent: float
    exponent_std: float
    rx_bias_db: dict[int, float]
    tx_level_db: dict[int, float]  # P_s: transmit power minus the first-metre loss
    sigma_db: float  # root-mean-square residual, corrected for the parameters fitted
    robust_scale_db: float  # the Student-t scale s
    n_samples: int
    #: The links' gain at each elevation knot (dB, 0 at the first, level), when fitted.
    elevation_knots_deg: tuple[float, ...] = ()
    elevation_gain_db: tuple[float, ...] = ()

    def elevation_gain_of(self, elevation_deg: FloatArray) -> FloatArray:
        """The fitted gain (dB) at links of ``elevation_deg`` (0 without a fit of it)."""
        if not self.elevation_knots_deg:
            return np.zeros_like(elevation_deg)
        gain: FloatArray = np.interp(
            elevation_deg, self.elevation_knots_deg, self.elevation_gain_db
        )
        return gain

    def bias_of(self, sysids: IntArray) -> FloatArray:
        """``(k,)`` biases of receivers ``sysids`` (0 for a receiver never seen)."""
        table = self._bias_by_sysid
        if sysids.size and (sysids.min() < 0 or sysids.max() >= table.shape[0]):
            return np.array([self.rx_bias_db.get(int(s), 0.0) for s in sysids], dtype=np.float64)
        return table[sysids]

    @functools.cached_property
    def _bias_by_sysid(self) -> FloatArray:
        """``rx_bias_db`` as a table on system id (a MAVLink system id is one byte), 0 where
        a receiver was never seen: one lookup per claim instead of one per reception."""
        table = np.zeros(256)
        for sysid, bias_db in self.rx_bias_db.items():
            if 0 <= sysid < table.shape[0]:
                table[sysid] = bias_db
        return table


def fit_channel(
    tx_sysid: IntArray,
    rx_sysid: IntArray,
    distance_m: FloatArray,
    rssi_dbm: FloatArray,
    cfg: CalibrationConfig,
    elevation_deg: FloatArray | None = None,
    floor_dbm: float = -math.inf,
) -> ChannelEstimate:
    """Fit ``(K,)`` labelled receptions (see the module docstring); with
    ``cfg.elevation_knots_deg`` and the links' ``elevation_deg``, a gain by elevation too
    (piecewise linear between the knots, 0 at level); with a finite ``floor_dbm`` (the
    receivers' sensitivity: nothing weaker was reported), on the RSSI less each link's
    expected lift above its mean (``censoring.py``)."""
    tx_ids, tx_col = np.unique(tx_sysid, return_inverse=True)
    rx_ids, rx_col = np.unique(rx_sysid, return_inverse=True)
    k, n_tx, n_rx = rssi_dbm.shape[0], tx_ids.shape[0], rx_ids.shape[0]
    knots = cfg.elevation_knots_deg if elevation_deg is not None else ()
    n_elev = max(len(knots) - 1, 0)
    i_exp = n_tx + n_rx
    n_params = i_exp + 1 + n_elev
    dense = np.zeros((k, 1 + n_elev))
    dense[:, 0] = -10.0 * np.log10(np.maximum(distance_m, 1.0))
    if n_elev:
        assert elevation_deg is not None
        dense[:, 1:] = _hat_basis(elevation_deg, knots)[:, 1:]
    design = Design(tx_col.astype(np.int64), rx_col.astype(np.int64), n_tx, n_rx, dense)
    prior_precision = np.zeros(n_params)
    prior_mean = np.zeros(n_params)
    prior_precision[n_tx:i_exp] = 1.0 / cfg.receiver_bias_prior_std_db**2
    prior_precision[i_exp] = 1.0 / cfg.exponent_prior_std**2
    prior_mean[i_exp] = cfg.exponent_prior
    prior_precision[i_exp + 1 :] = 1.0 / cfg.elevation_gain_prior_std_db**2
    prior_precision[:n_tx] = 1e-8  # flat, but keeps the system regular
    fit = functools.partial(_censored_irls, design, rssi_dbm, prior_mean, cfg, floor_dbm)
    theta, covariance, scale2, target_dbm = fit(prior_precision)
    if n_elev:
        # A knot the receptions cannot tell from 0 dB is held there: its estimate would be
        # noise that repeats on every link at that elevation for the rest of the run.
        gain = slice(i_exp + 1, n_params)
        standard_error = np.sqrt(np.diag(covariance)[gain])
        held = np.abs(theta[gain]) < cfg.elevation_gain_min_z * standard_error
        if held.any():
            prior_precision[gain] = np.where(held, _PINNED_PRECISION, prior_precision[gain])
            theta, covariance, scale2, target_dbm = fit(prior_precision)
            theta[gain] = np.where(held, 0.0, theta[gain])  # exactly: within 1e-12 already
    residual = target_dbm - design.predict(theta)
    return ChannelEstimate(
        exponent=float(theta[i_exp]),
        exponent_std=float(np.sqrt(covariance[i_exp, i_exp])),
        rx_bias_db={int(s): float(b) for s, b in zip(rx_ids, theta[n_tx:i_exp], strict=True)},
        tx_level_db={int(s): float(p) for s, p in zip(tx_ids, theta[:n_tx], strict=True)},
        sigma_db=float(np.sqrt(np.sum(residual**2) / max(k - n_params, 1))),
        robust_scale_db=float(np.sqrt(scale2)),
        n_samples=k,
        elevation_knots_deg=tuple(knots),
        elevation_gain_db=(0.0, *(float(g) for g in theta[i_exp + 1 :])) if n_elev else (),
    )


@dataclass(frozen=True, eq=False)
class Design:
    """The fit's design matrix ``(K, n_tx + n_rx + D)`` as it is: a one in the column of each
    reception's transmitter and of its receiver, and ``dense`` ``(K, D)`` columns (the
    log-distance term, the knots' weights). The normal equations come from group sums,
    O(K D^2), where the matrix product was O(K p^2) (p ~ 35 at 16 aircraft)."""

    tx_col: IntArray
    rx_col: IntArray
    n_tx: int
    n_rx: int
    dense: FloatArray

    @property
    def n_params(self) -> int:
        return self.n_tx + self.n_rx + int(self.dense.shape[1])

    def predict(self, theta: FloatArray) -> FloatArray:
        """``design @ theta``."""
        d0 = self.n_tx + self.n_rx
        out: FloatArray = (
            theta[self.tx_col] + theta[self.n_tx + self.rx_col] + self.dense @ theta[d0:]
        )
        return out

    def transpose_times(self, v: FloatArray) -> FloatArray:
        """``design.T @ v``."""
        return np.concatenate(
            [
                np.bincount(self.tx_col, weights=v, minlength=self.n_tx),
                np.bincount(self.rx_col, weights=v, minlength=self.n_rx),
                self.dense.T @ v,
            ]
        )

    def gram(self, w: FloatArray) -> FloatArray:
        """``design.T @ diag(w) @ design``."""
        n_tx, n_rx, d0 = self.n_tx, self.n_rx, self.n_tx + self.n_rx
        out = np.zeros((self.n_params, self.n_params))
        tx_diag = np.arange(n_tx)
        rx_diag = n_tx + np.arange(n_rx)
        out[tx_diag, tx_diag] = np.bincount(self.tx_col, weights=w, minlength=n_tx)
        out[rx_diag, rx_diag] = np.bincount(self.rx_col, weights=w, minlength=n_rx)
        pair = self.tx_col * n_rx + self.rx_col
        cross = np.bincount(pair, weights=w, minlength=n_tx * n_rx).reshape(n_tx, n_rx)
        out[:n_tx, n_tx:d0] = cross
        out[n_tx:d0, :n_tx] = cross.T
        wd = self.dense * w[:, None]
        for j in range(self.dense.shape[1]):
            by_tx = np.bincount(self.tx_col, weights=wd[:, j], minlength=n_tx)
            by_rx = np.bincount(self.rx_col, weights=wd[:, j], minlength=n_rx)
            out[:n_tx, d0 + j] = out[d0 + j, :n_tx] = by_tx
            out[n_tx:d0, d0 + j] = out[d0 + j, n_tx:d0] = by_rx
        out[d0:, d0:] = wd.T @ self.dense
        return out


def _censored_irls(
    design: Design,
    rssi_dbm: FloatArray,
    prior_mean: FloatArray,
    cfg: CalibrationConfig,
    floor_dbm: float,
    prior_precision: FloatArray,
) -> tuple[FloatArray, FloatArray, float, FloatArray]:
    """``_irls`` and the RSSI it was fitted to: with a finite ``floor_dbm``, refitted on the
    RSSI less the lift expected at the previous pass's means, ``CENSORING_PASSES`` times
    (``censoring.py``)."""
    theta, covariance, scale2, weights = _irls(design, rssi_dbm, prior_mean, prior_precision, cfg)
    target_dbm = rssi_dbm
    if not math.isfinite(floor_dbm):
        return theta, covariance, scale2, target_dbm
    dof = max(design.dense.shape[0] - design.n_params, 1)
    for _ in range(CENSORING_PASSES):
        mean_dbm = design.predict(theta)
        sigma_db = float(np.sqrt(np.sum((target_dbm - mean_dbm) ** 2) / dof))
        lift_db = significant_lift_db(mean_dbm, floor_dbm, sigma_db)
        if not lift_db.any():
            break  # the cut binds on no link: the plain fit
        target_dbm = rssi_dbm - lift_db
        theta, covariance, scale2, weights = _irls(
            design, target_dbm, prior_mean, prior_precision, cfg, (weights, scale2)
        )
    return theta, covariance, scale2, target_dbm


def _irls(
    design: Design,
    rssi_dbm: FloatArray,
    prior_mean: FloatArray,
    prior_precision: FloatArray,
    cfg: CalibrationConfig,
    start: tuple[FloatArray, float] | None = None,
) -> tuple[FloatArray, FloatArray, float, FloatArray]:
    """(theta, its covariance (dB^2), the Student-t scale s^2, the last weights) by
    iteratively reweighted least squares with the priors (module docstring): from unit
    weights, ``IRLS_PASSES`` passes, or from a previous fit's weights and scale ``start``
    (the RSSI barely changed), ``WARM_IRLS_PASSES``."""
    k = rssi_dbm.shape[0]
    weights, scale2 = (np.ones(k), 1.0) if start is None else start
    theta = prior_mean
    normal = np.diag(prior_precision)
    for _ in range(IRLS_PASSES if start is None else WARM_IRLS_PASSES):
        # Priors are in units of the noise: scale them by 1 / s^2 relative to the data.
        normal = design.gram(weights) / scale2 + np.diag(prior_precision)
        rhs = design.transpose_times(weights * rssi_dbm) / scale2 + prior_precision * prior_mean
        theta = np.asarray(np.linalg.solve(normal, rhs), dtype=np.float64)
        residual = rssi_dbm - design.predict(theta)
        scale2 = max(float(np.sum(weights * residual**2) / k), 1e-6)
        weights = (cfg.student_dof + 1.0) / (cfg.student_dof + residual**2 / scale2)
    covariance = np.asarray(np.linalg.inv(normal), dtype=np.float64)
    return theta, covariance, scale2, weights


def _hat_basis(x: FloatArray, knots: tuple[float, ...]) -> FloatArray:
    """``(K, len(knots))``: the piecewise-linear interpolation weights of each x on the
    knots (x clipped to their range); row k times the knots' values is the interpolant."""
    xs = np.clip(x, knots[0], knots[-1])
    j = np.clip(np.searchsorted(knots, xs, side="right") - 1, 0, len(knots) - 2)
    lo, hi = np.asarray(knots)[j], np.asarray(knots)[j + 1]
    t = (xs - lo) / (hi - lo)
    out = np.zeros((x.shape[0], len(knots)))
    rows = np.arange(x.shape[0])
    out[rows, j] = 1.0 - t
    out[rows, j + 1] = t
    return out


@dataclass(frozen=True)
class ConfiguredChannelCheck:
    """How the labelled receptions fit the configured channel (module docstring)."""

    chi_square: float
    dof: int
    residual_std_db: float  # root-mean-square residual about each transmitter's level
    p_value: float  # P(chi2_dof >= chi_square) were the configured channel the truth
    fits: bool  # p_value >= the test's alpha

    def describe(self) -> str:
        return (
            f"residual std {self.residual_std_db:.2f} dB over {self.dof} degrees of freedom, "
            f"chi-square p = {self.p_value:.2g}"
        )


def check_configured_channel(
    tx_sysid: IntArray,
    distance_m: FloatArray,
    rssi_dbm: FloatArray,
    sigma_db: float,
    position_sigma_m: float,
    alpha: float,
) -> ConfiguredChannelCheck:
    """Test ``(K,)`` labelled receptions against free space with noise std ``sigma_db`` and
    a position error ``position_sigma_m`` per end (the detectors' variance,
    ``sigma^2 + (8.69 sigma_p / d)^2``), each transmitter's level fitted by weighted least
    squares; the configured channel fits unless the chi-square's p-value is below
    ``alpha``."""
    d = np.maximum(distance_m, 1.0)
    level = rssi_dbm + 20.0 * np.log10(d)  # P_s + e_k under the configured channel
    weight = 1.0 / (sigma_db**2 + (DB_PER_LN * position_sigma_m / d) ** 2)
    tx_ids, tx_col = np.unique(tx_sysid, return_inverse=True)
    fitted = np.bincount(tx_col, weight * level) / np.bincount(tx_col, weight)
    residual = level - fitted[tx_col]
    dof = max(rssi_dbm.shape[0] - tx_ids.shape[0], 1)
    chi_square = float(np.sum(weight * residual**2))
    p_value = float(chdtrc(dof, chi_square))  # the chi-square survival function
    return ConfiguredChannelCheck(
        chi_square=chi_square,
        dof=dof,
        residual_std_db=float(np.sqrt(np.sum(residual**2) / dof)),
        p_value=p_value,
        fits=p_value >= alpha,
    )
