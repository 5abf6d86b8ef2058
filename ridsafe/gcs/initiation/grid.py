r"""Where to start a track: a grid posterior over position from the first few transmissions.

One NLLS fix is a poor start when the receivers are few or clustered (aircraft waiting at a
depot): the fix lands in one of several equally good minima with a covariance that knows
nothing of the others. Instead, the posterior of a transmitter held static over the first
transmissions (at most ``INIT_SPAN_S`` apart) is evaluated on a grid, with the unknown
transmit power profiled out (it is constant: one power for all receptions)::

    y_i(p) = z_i + 20 log10(max(||p - r_i||, 1)) + L          (implied power, paper eq. (8))
    Pt^(p) = mean(y),   C(p) = sum (y_i - Pt^(p))^2 / s^2,   pi(p | z) ~ exp(-C(p) / 2)

(flat priors on position and power; one cell's mass is exp(-C/2) times its area). With
``per_message_power`` each transmission gets its own profiled power (a transmitter that draws
a new power per message): C(p) sums each message's spread about its own mean, Pt^ is the
mean of the messages' powers.

1. coarse cells of ``cell_m`` over the receivers' extent plus ``margin_m``, at each altitude
   hypothesis;
2. the posterior's local modes: cells no costlier than their eight neighbours, the
   ``max_seeds`` cheapest over all altitudes;
3. around each mode the 3 x 3 coarse cells are replaced by ``fine_m`` cells, so a peak narrower
   than a coarse cell (many receivers, little noise) gets its mass instead of falling between
   cell centres and losing out to a broad valley;
4. each mode's basin (the cells of its altitude nearer to it than to the other modes) gives
   one Gaussian-sum seed: its mass, the horizontal mean and covariance (plus each cell's own
   variance cell^2/12 and the transmitter's motion over the span), the power's moments.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import LOSS_AT_1M_2400MHZ_DB
from ridsafe.gcs.initiation.grid_kernels import grid_costs
from ridsafe.gcs.pipeline_api import ObservedClaim

FloatArray = NDArray[np.float64]

__all__ = ["INIT_SPAN_S", "GridSeed", "grid_posterior", "init_windows", "spread_m"]

#: Transmissions used by the grid lie within this span (s) by default: the transmitter is held
#: static (``TrackConfig.init_spans_s`` may offer longer ones).
INIT_SPAN_S = 2.5
#: Largest speed assumed while held static (m/s), for the motion blur of the grid estimate.
MAX_SPEED_M_S = 8.0


@dataclass(frozen=True, eq=False)
class GridSeed:
    """One posterior mode's share of the grid posterior."""

    weight: float
    altitude_m: float
    p_xy_m: FloatArray  # (2,)
    cov_xy_m2: FloatArray  # (2, 2)
    tx_power_dbm: float
    tx_power_var_db2: float


@dataclass(frozen=True, eq=False)
class _Cells:
    """Evaluated cells of one altitude: centres (G, 2), side (G,), cost (G,), power (G,)."""

    xy: FloatArray
    side: FloatArray
    cost: FloatArray
    power: FloatArray


def init_windows(
    claims: Sequence[ObservedClaim],
    min_receivers: int,
    after_s: float = -np.inf,
    spans_s: Sequence[float] = (INIT_SPAN_S,),
) -> list[list[ObservedClaim]]:
    """Candidate groups of transmissions for the grid, oldest first: each usable transmission
    (>= ``min_receivers``) heard after ``after_s`` with the usable ones up to each of
    ``spans_s`` before it, shortest span first (a longer span that adds no claim is left
    out)."""
    usable = [claim for claim in claims if claim.n_receivers >= min_receivers]
    windows: list[list[ObservedClaim]] = []
    for last in usable:
        if last.t_s <= after_s:
            continue
        previous = 0
        for span_s in spans_s:
            window = [u for u in usable if last.t_s - span_s <= u.t_s <= last.t_s]
            if len(window) > previous:
                windows.append(window)
                previous = len(window)
    return windows


def _axes(rx: FloatArray, cell_m: float, margin_m: float) -> tuple[FloatArray, FloatArray]:
    lo = rx[:, :2].min(axis=0) - margin_m
    hi = rx[:, :2].max(axis=0) + margin_m
    return np.arange(lo[0], hi[0] + cell_m, cell_m), np.arange(lo[1], hi[1] + cell_m, cell_m)


def _local_minima(cost: FloatArray) -> NDArray[np.intp]:
    """Flat indices of cells of the 2D ``cost`` no costlier than their eight neighbours."""
    padded = np.pad(cost, 1, constant_values=np.inf)
    nx, ny = cost.shape
    is_min = np.ones_like(cost, dtype=bool)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            if dx or dy:
                is_min &= cost <= padded[1 + dx : 1 + dx + nx, 1 + dy : 1 + dy + ny]
    return np.flatnonzero(is_min)


Parts = Sequence[tuple[FloatArray, FloatArray]]  # (rx, z) of each group with one power


def _evaluate(
    xy: FloatArray, altitudes_m: Sequence[float], parts: Parts, s2: float
) -> tuple[FloatArray, FloatArray]:
    """Cost C / s^2 and profiled power at every cell of ``xy`` and altitude: (A, G) each."""
    altitudes = np.asarray(altitudes_m, float)
    if len(parts) == 1:
        rx, z = parts[0]
        cost, power = grid_costs(xy, altitudes, rx, z, LOSS_AT_1M_2400MHZ_DB)
        return cost / s2, power
    cost = np.zeros((altitudes.shape[0], xy.shape[0]))
    power = np.zeros_like(cost)
    for rx, z in parts:
        c, p = grid_costs(xy, altitudes, rx, z, LOSS_AT_1M_2400MHZ_DB)
        cost += c
        power += p / len(parts)
    return cost / s2, power


def _basin(coarse: _Cells, mine: NDArray[np.bool_], fine: _Cells) -> _Cells:
    """The coarse cells ``mine`` (the mode's, its 3 x 3 neighbourhood excluded), then
    ``fine`` (that neighbourhood at the fine resolution)."""
    return _Cells(
        np.concatenate((coarse.xy[mine], fine.xy)),
        np.concatenate((coarse.side[mine], fine.side)),
        np.concatenate((coarse.cost[mine], fine.cost)),
        np.concatenate((coarse.power[mine], fine.power)),
    )


def _outside_neighbourhood(index: int, shape: tuple[int, int]) -> NDArray[np.bool_]:
    """Flat mask of the grid's cells outside the 3 x 3 cells about flat ``index``."""
    ix, iy = divmod(index, shape[1])
    mask = np.ones(shape, dtype=bool)
    mask[max(ix - 1, 0) : ix + 2, max(iy - 1, 0) : iy + 2] = False
    return mask.ravel()


def _moments(
    cells: _Cells, c_min: float, blur: FloatArray, k: int, s2: float, alt: float
) -> GridSeed | None:
    """The basin's mass and moments; None when its mass underflows to 0 (a mode so much
    worse than the best that no cell of it carries weight, e.g. at a small noise std)."""
    w = np.exp(-0.5 * (cells.cost - c_min)) * cells.side**2
    total = float(w.sum())
    if not total > 0.0:
        return None
    wn = w / total
    mean = wn @ cells.xy
    d = cells.xy - mean
    cov = (d * wn[:, None]).T @ d + (wn @ cells.side**2 / 12.0) * np.eye(2) + blur
    pt = float(wn @ cells.power)
    pt_var = float(wn @ (cells.power - pt) ** 2) + s2 / k
    return GridSeed(total, float(alt), mean, cov, pt, pt_var)


def _coarse_grid(
    rx: FloatArray,
    parts: Parts,
    altitudes_m: Sequence[float],
    s2: float,
    cell_m: float,
    margin_m: float,
) -> tuple[list[_Cells], tuple[int, int]]:
    """Every coarse cell at every altitude (one pass over the cells), and the grid's shape
    (the flat index of cell (ix, iy) is ix * ny + iy)."""
    xs, ys = _axes(rx, cell_m, margin_m)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    xy = np.column_stack((gx.ravel(), gy.ravel()))
    cost, power = _evaluate(xy, altitudes_m, parts, s2)
    side = np.full(xy.shape[0], cell_m)
    cells = [_Cells(xy, side, cost[a], power[a]) for a in range(len(altitudes_m))]
    return cells, (xs.shape[0], ys.shape[0])


@functools.cache
def _fine_offsets(cell_m: float, fine_m: float) -> FloatArray:
    """Centres of the ``fine_m`` cells over 3 x 3 coarse cells, about the middle: (F, 2)."""
    offsets = np.arange(-1.5 * cell_m + fine_m / 2, 1.5 * cell_m, fine_m)
    fx, fy = np.meshgrid(offsets, offsets, indexing="ij")
    out = np.column_stack((fx.ravel(), fy.ravel()))
    out.setflags(write=False)
    return out


def _fine_window(
    centre: FloatArray,
    alt: float,
    parts: Parts,
    s2: float,
    cell_m: float,
    fine_m: float,
) -> _Cells:
    """``fine_m`` cells over the 3 x 3 coarse cells about ``centre``."""
    xy = centre + _fine_offsets(cell_m, fine_m)
    cost, power = _evaluate(xy, (alt,), parts, s2)
    return _Cells(xy, np.full(xy.shape[0], fine_m), cost[0], power[0])


def grid_posterior(
    claims: Sequence[ObservedClaim],
    altitudes_m: Sequence[float],
    sigma_db: float,
    cell_m: float = 50.0,
    margin_m: float = 500.0,
    fine_m: float = 10.0,
    max_seeds: int = 6,
    per_message_power: bool = False,
) -> list[GridSeed]:
    """One seed per retained posterior mode (module docstring); weights sum to 1."""
    rx = np.ascontiguousarray(np.vstack([claim.rx_p_enu_m for claim in claims]))
    z = np.ascontiguousarray(np.concatenate([claim.rssi_dbm for claim in claims]))
    groups: Parts = [(rx, z)]
    if per_message_power and len(claims) > 1:
        groups = [
            (np.ascontiguousarray(c.rx_p_enu_m), np.ascontiguousarray(c.rssi_dbm)) for c in claims
        ]
    s2 = sigma_db**2
    coarse, shape = _coarse_grid(rx, groups, altitudes_m, s2, cell_m, margin_m)
    modes = sorted(
        (float(c.cost[i]), a, int(i))
        for a, c in enumerate(coarse)
        for i in _local_minima(c.cost.reshape(shape))
    )[:max_seeds]
    span = max(claim.t_s for claim in claims) - min(claim.t_s for claim in claims)
    blur = (MAX_SPEED_M_S * span / 2.0) ** 2 * np.eye(2)
    xy = coarse[0].xy  # the same cells at every altitude
    centres = xy[[i for _, _, i in modes]]
    d2 = np.sum((xy[:, None, :] - centres[None, :, :]) ** 2, axis=2)  # (G, modes)
    parts: list[tuple[_Cells, float]] = []
    for m, (_, a, i) in enumerate(modes):
        fine = _fine_window(centres[m], altitudes_m[a], groups, s2, cell_m, fine_m)
        layer = [n for n, (_, b, _) in enumerate(modes) if b == a]
        mine = d2[:, m] <= d2[:, layer].min(axis=1)  # no farther than its layer's other modes
        mine &= _outside_neighbourhood(i, shape)
        parts.append((_basin(coarse[a], mine, fine), altitudes_m[a]))
    c_min = min(float(p.cost.min()) for p, _ in parts)
    moments = (_moments(cells, c_min, blur, z.shape[0], s2, alt) for cells, alt in parts)
    seeds = [seed for seed in moments if seed is not None]  # the best mode's mass is > 0
    total = sum(s.weight for s in seeds)
    return [replace(s, weight=s.weight / total) for s in seeds]


def spread_m(seeds: Sequence[GridSeed]) -> float:
    """Largest horizontal std (m) of the grid posterior, all seeds together (a mixture's
    covariance includes the spread of its modes: a start among far-apart modes waits)."""
    w = np.array([s.weight for s in seeds])
    w = w / w.sum()
    xy = np.array([s.p_xy_m for s in seeds])
    mean = w @ xy
    d = xy - mean
    cov = np.einsum("a,aij->ij", w, np.array([s.cov_xy_m2 for s in seeds]))
    cov += (d * w[:, None]).T @ d
    return float(np.sqrt(np.max(np.linalg.eigvalsh(cov))))
