"""Compiled (numba) kernel of the track-start grid (``grid.py``): the implied-power costs of
every cell at every altitude hypothesis. ``grid.py`` states the equations."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

FloatArray = NDArray[np.float64]

__all__ = ["grid_costs"]


@jit
def _grid_costs(
    xy: FloatArray, altitudes: FloatArray, rx: FloatArray, z: FloatArray, loss: float
) -> tuple[FloatArray, FloatArray]:
    n_a, n_g, k = altitudes.shape[0], xy.shape[0], rx.shape[0]
    cost = np.empty((n_a, n_g))
    power = np.empty((n_a, n_g))
    scale = 10.0 / math.log(10.0)
    y = np.empty(k)
    h2 = np.empty(k)
    for g in range(n_g):
        for i in range(k):
            h2[i] = (xy[g, 0] - rx[i, 0]) ** 2 + (xy[g, 1] - rx[i, 1]) ** 2
        for a in range(n_a):
            total = 0.0
            for i in range(k):
                d2 = max(h2[i] + (altitudes[a] - rx[i, 2]) ** 2, 1.0)
                y[i] = z[i] + scale * math.log(d2) + loss
                total += y[i]
            mean = total / k
            c = 0.0
            for i in range(k):
                c += (y[i] - mean) ** 2
            cost[a, g] = c
            power[a, g] = mean
    return cost, power


def grid_costs(
    xy: FloatArray, altitudes: FloatArray, rx: FloatArray, z: FloatArray, loss: float
) -> tuple[FloatArray, FloatArray]:
    """For the track-start grid (``grid.py``): at every cell and altitude, the profiled
    power Pt^ = mean(y) and C = sum (y - Pt^)^2 of the implied powers y_i = z_i +
    20 log10(max(d_i, 1)) + L (equal weights; divide by s^2 outside): (A, G) each."""
    out: tuple[FloatArray, FloatArray] = _grid_costs(xy, altitudes, rx, z, loss)
    return out
