"""Compiled (numba) kernel of one observed claim through every RSSI-consistency detector.

Same equations as the numpy functions of ``rssi_consistency.py`` (``implied_powers``,
``sufficient_statistics``, ``spread_test``, ``offset_score_test``, ``PairNis.step``), which
the tests compare against; one call per claim instead of ~60 numpy calls. After editing,
delete ``ridsafe/gcs/detection/__pycache__/*.nb[ci]`` (numba's cache does not track other
modules).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit
from ridsafe.common.pathloss import DB_PER_LN

FloatArray = NDArray[np.float64]

__all__ = [
    "N_PARAMS",
    "ROW",
    "observe_batch_kernel",
    "observe_kernel",
    "observe_params",
    "score_from_sums",
]

ROW = 19  # n, sw, swy, swyy, swg (3), swgy (3), swgg (9)
RANK_TOL = 1e-9


@jit
def score_from_sums(s: FloatArray) -> tuple[float, int, float, int, FloatArray]:
    """(spread T, its dof, offset score T, its rank, delta^ (3,)) from one row of sums."""
    sw = s[1]
    pt = s[2] / sw
    rss = max(s[3] - s[2] * s[2] / sw, 0.0)
    b = np.empty(3)
    A = np.empty((3, 3))
    for i in range(3):
        b[i] = s[7 + i] - s[4 + i] * pt
        for j in range(3):
            A[i, j] = s[10 + 3 * i + j] - s[4 + i] * s[4 + j] / sw
    A = 0.5 * (A + A.T)
    lam, V = np.linalg.eigh(A)
    top = max(lam[2], 1e-300)
    T = 0.0
    rank = 0
    delta = np.zeros(3)
    for c in range(3):
        if lam[c] > RANK_TOL * top:
            proj = V[0, c] * b[0] + V[1, c] * b[1] + V[2, c] * b[2]
            coef = proj / lam[c]
            T += proj * coef
            rank += 1
            for i in range(3):
                delta[i] += V[i, c] * coef
    return rss, int(s[0]) - 1, T, rank, delta


@jit
def _tx_row(
    claimed: FloatArray,
    rx: FloatArray,
    rssi: FloatArray,
    y_ref: float,
    s2: float,
    pos2: float,
    loss: float,
    y: FloatArray,
    d: FloatArray,
) -> FloatArray:
    """This transmission's row of sums; fills ``y`` (implied powers) and ``d`` (distances).
    The offset gradient is kept in scalars (no array per reception); the operations and their
    order are those of the numpy reference."""
    row = np.zeros(ROW)
    k = rx.shape[0]
    row[0] = k
    for i in range(k):
        g0 = claimed[0] - rx[i, 0]
        g1 = claimed[1] - rx[i, 1]
        g2 = claimed[2] - rx[i, 2]
        d2 = max(g0 * g0 + g1 * g1 + g2 * g2, 1.0)
        d[i] = math.sqrt(d2)
        y[i] = rssi[i] + 10.0 * math.log10(d2) + loss
        w = 1.0 / (s2 + pos2 / d2)
        yc = y[i] - y_ref
        row[1] += w
        row[2] += w * yc
        row[3] += w * yc * yc
        scale = DB_PER_LN / d2
        g0 *= scale
        g1 *= scale
        g2 *= scale
        wg0, wg1, wg2 = w * g0, w * g1, w * g2
        row[4] += wg0
        row[5] += wg1
        row[6] += wg2
        row[7] += wg0 * yc
        row[8] += wg1 * yc
        row[9] += wg2 * yc
        row[10] += wg0 * g0
        row[11] += wg0 * g1
        row[12] += wg0 * g2
        row[13] += wg1 * g0
        row[14] += wg1 * g1
        row[15] += wg1 * g2
        row[16] += wg2 * g0
        row[17] += wg2 * g1
        row[18] += wg2 * g2
    return row


#: Layout of ``observe_kernel``'s ``params`` (``observe_params``).
P_WINDOW_S, P_S2, P_POS2, P_LOSS, P_NIS_Q, P_NIS_R, P_NIS_P0, P_LONG_WINDOW_S = range(8)
N_PARAMS = 8


def observe_params(
    window_s: float,
    s2: float,
    pos2: float,
    loss: float,
    nis_q: float,
    nis_r: float,
    nis_p0: float,
    long_window_s: float = 0.0,
) -> FloatArray:
    """The constants of ``observe_kernel`` packed once per transmitter (one argument to
    pass instead of eight); ``long_window_s`` 0: no long window."""
    values = [window_s, s2, pos2, loss, nis_q, nis_r, nis_p0, long_window_s]
    return np.array(values, dtype=np.float64)


@jit
def observe_kernel(
    claimed: FloatArray,
    rx: FloatArray,
    rssi: FloatArray,
    rx_sysid: NDArray[np.int64],
    pair_x: FloatArray,
    pair_P: FloatArray,
    pair_started: NDArray[np.bool_],
    ring: FloatArray,
    ring_t: FloatArray,
    t_s: float,
    y_ref: float,
    params: FloatArray,
) -> tuple[float, float, int, float, int, float, int, float, int, FloatArray, float, int]:
    """One transmission: (max pair NIS, spread T, dof, window spread T, dof, single-tx offset
    T, rank, window offset T, rank, window delta^, long-window offset T, rank (0, 0 without
    a long window)). Updates the pair filters (one slot per MAVLink system id,
    ``rx_sysid & 0xFF``) and the ring (the oldest slot is replaced) in place. ``params``
    from ``observe_params``; its ``pos2`` = (20/ln10 sigma_pos)^2."""
    window_s, s2, pos2 = params[P_WINDOW_S], params[P_S2], params[P_POS2]
    long_window_s = params[P_LONG_WINDOW_S]
    nis_q, nis_r, nis_p0 = params[P_NIS_Q], params[P_NIS_R], params[P_NIS_P0]
    k = rx.shape[0]
    y = np.empty(k)
    d = np.empty(k)
    row = _tx_row(claimed, rx, rssi, y_ref, s2, pos2, params[P_LOSS], y, d)
    nis_max = 0.0
    for i in range(k):
        j = rx_sysid[i] & 0xFF
        if pair_started[j]:
            P = pair_P[j] + nis_q
            S = P + nis_r + pos2 / (d[i] * d[i])
            nu = y[i] - pair_x[j]
            nis_max = max(nis_max, nu * nu / S)
            K = P / S
            pair_x[j] += K * nu
            pair_P[j] = (1.0 - K) * P
        else:
            pair_x[j] = y[i]
            pair_P[j] = nis_p0
            pair_started[j] = True
    slot = int(np.argmin(ring_t))
    ring[slot] = row
    ring_t[slot] = t_s
    window = np.zeros(ROW)
    long_window = np.zeros(ROW)
    for r in range(ring.shape[0]):
        if ring_t[r] > t_s - window_s:
            window += ring[r]
        if ring_t[r] > t_s - long_window_s:
            long_window += ring[r]
    spread, dof, one, rank_one, _ = score_from_sums(row)
    wspread, wdof, win, rank_win, delta = score_from_sums(window)
    lwin, rank_lwin = 0.0, 0
    if long_window_s > 0.0:
        lwin, rank_lwin = score_from_sums(long_window)[2:4]
    return nis_max, spread, dof, wspread, wdof, one, rank_one, win, rank_win, delta, lwin, rank_lwin


@jit
def observe_batch_kernel(
    claimed: FloatArray,
    rx: FloatArray,
    rssi: FloatArray,
    rx_sysid: NDArray[np.int64],
    bounds: NDArray[np.int64],
    t_s: FloatArray,
    rows: NDArray[np.int64],
    pair_x: FloatArray,
    pair_P: FloatArray,
    pair_started: NDArray[np.bool_],
    ring: FloatArray,
    ring_t: FloatArray,
    y_ref: FloatArray,
    params: FloatArray,
) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """``observe_kernel`` on B claims in order, each on its transmitter's row of stacked
    state: claim j is ``claimed[j]`` (B, 3) heard by receptions ``bounds[j]:bounds[j + 1]``
    of ``rx`` (R, 3), ``rssi``, ``rx_sysid``, at ``t_s[j]``; its transmitter's state is row
    ``rows[j]`` of ``pair_x``, ``pair_P``, ``pair_started`` (M, 256), ``ring`` (M, RING, ROW),
    ``ring_t`` (M, RING), ``y_ref`` (M,), ``params`` (M, N_PARAMS). The same arithmetic as
    one call per claim. Returns (stats (B, 6): max pair NIS, spread T, window spread T,
    single-tx offset T, window offset T, long-window offset T; dofs (B, 5): spread dof, window
    dof, rank, window rank, long-window rank; window delta^ (B, 3))."""
    b = claimed.shape[0]
    stats = np.zeros((b, 6))
    dofs = np.zeros((b, 5), dtype=np.int64)
    deltas = np.zeros((b, 3))
    for j in range(b):
        r = rows[j]
        lo, hi = bounds[j], bounds[j + 1]
        (nis, spread, dof, wspread, wdof, one, rank_one, win, rank_win, delta, lwin, rank_lwin) = (
            observe_kernel(
                claimed[j],
                rx[lo:hi],
                rssi[lo:hi],
                rx_sysid[lo:hi],
                pair_x[r],
                pair_P[r],
                pair_started[r],
                ring[r],
                ring_t[r],
                t_s[j],
                y_ref[r],
                params[r],
            )
        )
        stats[j, 0] = nis
        stats[j, 1] = spread
        stats[j, 2] = wspread
        stats[j, 3] = one
        stats[j, 4] = win
        stats[j, 5] = lwin
        dofs[j, 0] = dof
        dofs[j, 1] = wdof
        dofs[j, 2] = rank_one
        dofs[j, 3] = rank_win
        dofs[j, 4] = rank_lwin
        deltas[j] = delta
    return stats, dofs, deltas
