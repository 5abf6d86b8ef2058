"""Compiled (numba) kernel of the cooperative labeller's per-claim work (``cooperative.py``):
each claim of a cycle updates its receivers' newest positions, then is matched against them,
in the claims' order, in one call instead of a dozen numpy calls per claim.
``tests/gcs/calibration/test_cooperative.py`` compares it with the rule written out claim by
claim in numpy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit

FloatArray = NDArray[np.float64]

__all__ = ["update_and_match"]


@jit
def update_and_match(
    rows: NDArray[np.intp],
    rx_t_s: FloatArray,
    rx_p_enu_m: FloatArray,
    bounds: NDArray[np.int64],
    claim_t_s: FloatArray,
    claim_p_enu_m: FloatArray,
    newest_t_s: FloatArray,
    newest_p_enu_m: FloatArray,
    match_age_s: float,
    match_m: float,
) -> NDArray[np.intp]:
    """For claim j (receptions ``bounds[j]:bounds[j + 1]`` on receiver rows ``rows``): take
    the newer of each receiver's positions into ``newest_*`` (in place), then the one row
    whose position, at most ``match_age_s`` from the claim's time, lies within ``match_m``
    of the claimed position among the receivers that did not hear it; -1 when none or
    several."""
    n_claims = claim_t_s.shape[0]
    n_rows = newest_t_s.shape[0]
    heard = np.zeros(n_rows, dtype=np.bool_)
    out = np.full(n_claims, -1, dtype=np.intp)
    match_m2 = match_m * match_m
    for j in range(n_claims):
        for i in range(bounds[j], bounds[j + 1]):
            row = rows[i]
            if rx_t_s[i] >= newest_t_s[row]:
                newest_t_s[row] = rx_t_s[i]
                for a in range(3):
                    newest_p_enu_m[row, a] = rx_p_enu_m[i, a]
            heard[row] = True
        t = claim_t_s[j]
        found, count = -1, 0
        for row in range(n_rows):
            if heard[row] or not abs(newest_t_s[row] - t) <= match_age_s:
                continue
            d2 = 0.0
            for a in range(3):
                diff = newest_p_enu_m[row, a] - claim_p_enu_m[j, a]
                d2 += diff * diff
            if d2 <= match_m2:
                found, count = row, count + 1
        if count == 1:
            out[j] = found
        for i in range(bounds[j], bounds[j + 1]):
            heard[rows[i]] = False
    return out
