r"""Compiled (numba) likelihood-ratio test of a claimed position on a censored channel.

One transmitter's window of claims as *terms*, one per (claim, listening receiver): the
claimed position less the receiver's (``diff``), whether it heard the claim, its RSSI, and
the receiver's cut (``floor``: nothing weaker is reported), and its noise std ``sigma``. With
mu = P - 10 n log10 ||diff - delta|| (P the power less the 1 m loss), a term contributes to
the log-likelihood

* heard: log phi((rssi - mu) / s), and with ``misses`` off, - log(1 - Phi((floor - mu) / s))
  (the reception given that it was heard: a normal truncated at the cut);
* not heard (``misses`` on): log(q + (1 - q) Phi((floor - mu) / s)), q a miss the channel
  always allows (packet loss).

``offset_glrt`` returns T = 2 (max l(delta, P) - max l(0, P)), about chi2_3 for an honest
claim: the search starts at delta = 0 and at the best points of a grid of offsets, each
refined by BFGS with a backtracking line search. The GCS's MLAT_CENSORED detector
(``censored.py``) runs it on the receptions alone; ``tools/analysis/censored_evidence.py``
also with the misses, on a log's claims (docs/results/robustness.md, "Who did not hear
it"). After editing, delete
``ridsafe/gcs/detection/__pycache__/*.nb[ci]`` (numba's cache does not track other
modules).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit, jit_inline

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = ["censored_nll", "log_norm_cdf", "offset_glrt"]

_SQRT2 = math.sqrt(2.0)
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)
_DB_PER_LN = 10.0 / math.log(10.0)
#: Below this, log Phi by its asymptotic series (erfc underflows near -37).
_ASYMPTOTIC_BELOW = -30.0
#: Exponents of density ratios are clipped here (a search straying far from the claim).
_MAX_EXP = 700.0
#: BFGS: at most this many iterations and line-search halvings; the first inverse Hessian
#: scales delta (m) and P (dB) so that a unit gradient is a step of 30 m or 3 dB.
_MAX_ITERATIONS = 200
_MAX_HALVINGS = 40
_INITIAL_SCALE = np.array([30.0, 30.0, 30.0, 3.0]) ** 2
#: Grid points kept as starts besides delta = 0.
_GRID_STARTS = 2


@jit_inline
def log_norm_cdf(x: float) -> float:
    """log Phi(x), accurate in both tails."""
    if x > 0.0:
        return math.log1p(-0.5 * math.erfc(x / _SQRT2))
    if x > _ASYMPTOTIC_BELOW:
        return math.log(0.5 * math.erfc(-x / _SQRT2))
    x2 = x * x
    return -0.5 * x2 - math.log(-x) - _HALF_LOG_2PI + math.log1p(-1.0 / x2 + 3.0 / (x2 * x2))


@jit
def censored_nll(
    theta: FloatArray,
    diff: FloatArray,
    heard: BoolArray,
    rssi: FloatArray,
    floor: FloatArray,
    exponent: float,
    sigma: FloatArray,
    miss_floor: float,
    misses: bool,
) -> tuple[float, FloatArray]:
    """-l(delta, P) at ``theta`` = (delta (3,), P) and its gradient (module docstring)."""
    log_q, log_1q = math.log(miss_floor), math.log1p(-miss_floor)
    total = 0.0
    grad = np.zeros(4)
    for i in range(diff.shape[0]):
        dx = diff[i, 0] - theta[0]
        dy = diff[i, 1] - theta[1]
        dz = diff[i, 2] - theta[2]
        d2 = max(dx * dx + dy * dy + dz * dz, 1.0)
        mu = theta[3] - 0.5 * exponent * _DB_PER_LN * math.log(d2)
        s = sigma[i]
        a = (floor[i] - mu) / s
        log_pdf_a = -0.5 * a * a - _HALF_LOG_2PI
        if heard[i]:
            e = (rssi[i] - mu) / s
            total += 0.5 * e * e
            dnll_dmu = -e / s
            if not misses:
                log_heard = log_norm_cdf(-a)
                total += log_heard
                dnll_dmu += math.exp(min(log_pdf_a - log_heard, _MAX_EXP)) / s
        elif misses:
            b = log_1q + log_norm_cdf(a)
            hi, lo = max(log_q, b), min(log_q, b)
            log_miss = hi + math.log1p(math.exp(lo - hi))
            total -= log_miss
            dnll_dmu = math.exp(min(log_1q + log_pdf_a - log_miss, _MAX_EXP)) / s
        else:
            continue
        # d mu / d delta = 10 n / ln 10 * (diff - delta) / d^2 (moving the source away)
        k = dnll_dmu * exponent * _DB_PER_LN / d2
        grad[0] += k * dx
        grad[1] += k * dy
        grad[2] += k * dz
        grad[3] += dnll_dmu
    return total, grad


@jit
def _minimise(
    theta0: FloatArray,
    mask: FloatArray,
    diff: FloatArray,
    heard: BoolArray,
    rssi: FloatArray,
    floor: FloatArray,
    exponent: float,
    sigma: FloatArray,
    miss_floor: float,
    misses: bool,
) -> tuple[FloatArray, float]:
    """BFGS over the parameters ``mask`` frees (1.0), the others held at ``theta0``."""
    theta = theta0.copy()
    f, g = censored_nll(theta, diff, heard, rssi, floor, exponent, sigma, miss_floor, misses)
    g = g * mask
    h_inv = np.diag(_INITIAL_SCALE * mask)
    for _ in range(_MAX_ITERATIONS):
        step = -(h_inv @ g)
        slope = float(g @ step)
        if slope >= 0.0:  # not a descent direction: restart from the scaled gradient
            h_inv = np.diag(_INITIAL_SCALE * mask)
            step = -(h_inv @ g)
            slope = float(g @ step)
        if slope >= -1e-14:
            break
        t = 1.0
        accepted = False
        for _h in range(_MAX_HALVINGS):
            trial = theta + t * step
            f_new, g_new = censored_nll(
                trial, diff, heard, rssi, floor, exponent, sigma, miss_floor, misses
            )
            if f_new <= f + 1e-4 * t * slope:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        g_new = g_new * mask
        s = trial - theta
        y = g_new - g
        sy = float(s @ y)
        if sy > 1e-12:
            hy = h_inv @ y
            h_inv += ((sy + float(y @ hy)) / (sy * sy)) * np.outer(s, s)
            h_inv -= (np.outer(hy, s) + np.outer(s, hy)) / sy
        converged = abs(f - f_new) <= 1e-10 * (1.0 + abs(f))
        theta, f, g = trial, f_new, g_new
        if converged or np.max(np.abs(g)) < 1e-8:
            break
    return theta, f


@jit
def offset_glrt(
    diff: FloatArray,
    heard: BoolArray,
    rssi: FloatArray,
    floor: FloatArray,
    exponent: float,
    sigma: FloatArray,
    miss_floor: float,
    misses: bool,
    grid: FloatArray,
) -> float:
    """T = 2 (max l(delta, P) - max l(0, P)) over the terms; 0 when none was heard.
    ``grid`` (G, 3): the offsets whose best ``_GRID_STARTS`` start the search besides 0."""
    n_heard = 0
    for i in range(heard.shape[0]):
        n_heard += 1 if heard[i] else 0
    if n_heard == 0:
        return 0.0
    start = np.zeros(4)
    start[3] = np.median(rssi[heard])
    power_only = np.array([0.0, 0.0, 0.0, 1.0])
    null, f_null = _minimise(
        start, power_only, diff, heard, rssi, floor, exponent, sigma, miss_floor, misses
    )
    values = np.empty(grid.shape[0])
    probe = null.copy()
    for k in range(grid.shape[0]):
        probe[:3] = grid[k]
        values[k] = censored_nll(
            probe, diff, heard, rssi, floor, exponent, sigma, miss_floor, misses
        )[0]
    order = np.argsort(values)
    best = f_null
    everything = np.ones(4)
    for j in range(_GRID_STARTS + 1):
        theta0 = null.copy()
        if j > 0:
            theta0[:3] = grid[order[j - 1]]
        _, f = _minimise(
            theta0, everything, diff, heard, rssi, floor, exponent, sigma, miss_floor, misses
        )
        best = min(best, f)
    return max(2.0 * (f_null - best), 0.0)
