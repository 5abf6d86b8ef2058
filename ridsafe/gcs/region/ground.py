r"""Ghosts: a transmitter that stands on the ground while its Remote ID claims an aircraft.

A ghost (a Sybil drone) is a radio that claims an aircraft that does not exist. Its track
localises the radio, not the claim; the region around that estimate is harmless as long as
it is where the radio is. But RSSI says little about a transmitter's height (receivers on
the ground hear +h and -h alike, those in the air are a few hundred metres away), so the
estimate's vertical spread stays tens of metres for a minute: the region is a column from
the ground to above the cruise altitudes, which the planners fly around and which holds
every take-off near it.

With ``pipeline.ghosts.enabled`` an alerted transmitter is taken for a radio on the ground
when its track stands still while its claim flies. Every GCS cycle, over the last
``window_s`` (W) of the track's horizontal estimates x_h(t) and claimed positions c_h(t)::

    still  = max_t |x_h(t) - mean_W x_h| <= R        (R = still_radius_m; keep_radius_m once
             and |mean_W v_h| <= 2 R / W               recognised, so noise does not flicker it;
                                                       v_h the track's own velocity estimate)
    flies  = |c_h(now) - c_h(now - W)| >= min_claim_travel_m
    low    = z - k sigma_z <= z_g + H                 (the ground layer within k sigma of the
                                                       estimate's height; k = height_sigmas)
    ground = the track is W old, still and low, and (flies, or it was ground already)

(A transmitter slower than about 2 R / W, 2.7 m/s by default, counts as still.) A track that
lags its spoofer also stands still; its own velocity estimate is what tells it apart: on the
sweep of issue 16's cells, without that test, a pursuer at 50 m whose track sat 35 m low and
stuck while its velocity said 3-12 m/s was flattened for 1 s (8 aircraft, ``mixed``, seed 7).
A 10 s window, or the slope of the estimates instead of their spread, took tens of spoofers
for radios on the ground in the sweep before.
A transmitter on the ground gets a flat region: its horizontal estimate and covariance, from
the ground ``z_g`` (``rssi_filter.ground_z_enu_m``) to ``z_g + max_height_m``, not moving::

    c = (x_h, z_g + H/2),   P = [[P_h, 0], [0, (H/2)^2 / chi2]],   v = 0

so the vertical semi-axis is H/2 and the region spans [z_g, z_g + H]. The region is sent
with ``RegionFlags.ON_GROUND``: the companions hold a take-off or a landing only where it
covers the pad, and their planners do not fly around it (``companion/pad_clearance.py``).

What this assumes: a transmitter that stays put for W seconds while it claims to fly is on
the ground. A spoofer that hovers low where the aircraft take off, and lies about moving,
is taken for one; once it moves its track is no longer still and its full region returns
at the next cycle, but an aircraft already climbing by it cannot dodge. A ghost whose claim
hovers too is not recognised (its region stays as estimated).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.pipeline_config import GroundTransmitterConfig

FloatArray = NDArray[np.float64]

__all__ = ["GroundWatch", "flat_on_ground"]

_EPS_S = 1e-9


@dataclass
class _History:
    samples: deque[tuple[float, FloatArray, FloatArray, FloatArray]]  # t_s, x_h, v_h, c_h (2,)
    on_ground: bool = False


class GroundWatch:
    """Which alerted transmitters stand on the ground (module docstring), per uas_id."""

    def __init__(self, cfg: GroundTransmitterConfig, ground_z_enu_m: float) -> None:
        self.cfg = cfg
        self.ground_z_enu_m = ground_z_enu_m
        self._tracks: dict[str, _History] = {}

    def update(
        self,
        uas_id: str,
        t_s: float,
        estimate_enu_m: FloatArray,
        cov_enu_m2: FloatArray,
        velocity_enu_m_s: FloatArray,
        claim_enu_m: FloatArray,
    ) -> bool:
        """Add this cycle's estimate (mean, covariance, velocity) and latest claim of
        ``uas_id``; is it on the ground?"""
        history = self._tracks.setdefault(uas_id, _History(deque()))
        samples = history.samples
        samples.append(
            (
                t_s,
                np.array(estimate_enu_m[:2]),
                np.array(velocity_enu_m_s[:2]),
                np.array(claim_enu_m[:2]),
            )
        )
        window_s = self.cfg.window_s
        while len(samples) > 1 and samples[1][0] <= t_s - window_s + _EPS_S:
            samples.popleft()
        sigma_z_m = float(np.sqrt(max(float(cov_enu_m2[2, 2]), 0.0)))
        low = estimate_enu_m[2] - self.cfg.height_sigmas * sigma_z_m <= (
            self.ground_z_enu_m + self.cfg.max_height_m
        )
        history.on_ground = bool(low) and self._still_and_flying(history, t_s)
        return history.on_ground

    def _still_and_flying(self, history: _History, t_s: float) -> bool:
        samples = history.samples
        if t_s - samples[0][0] < self.cfg.window_s - _EPS_S:
            return False  # not watched for a whole window yet
        x_h = np.array([s[1] for s in samples])
        spread_m = float(np.max(np.hypot(*(x_h - x_h.mean(axis=0)).T)))
        radius_m = self.cfg.keep_radius_m if history.on_ground else self.cfg.still_radius_m
        speed_m_s = float(np.hypot(*np.mean([s[2] for s in samples], axis=0)))
        if spread_m > radius_m or speed_m_s > 2.0 * radius_m / self.cfg.window_s:
            return False
        claim_travel_m = float(np.hypot(*(samples[-1][3] - samples[0][3])))
        return history.on_ground or claim_travel_m >= self.cfg.min_claim_travel_m

    def forget(self, uas_id: str) -> None:
        """Drop ``uas_id``'s history (its track was deleted)."""
        self._tracks.pop(uas_id, None)


def flat_on_ground(
    estimate_enu_m: FloatArray,
    cov_enu_m2: FloatArray,
    ground_z_enu_m: float,
    max_height_m: float,
    chi2_threshold: float,
) -> tuple[FloatArray, FloatArray]:
    """(centre, covariance) of the flat region on the ground (module docstring)."""
    half_m = 0.5 * max_height_m
    centre = np.array([estimate_enu_m[0], estimate_enu_m[1], ground_z_enu_m + half_m])
    cov = np.zeros((3, 3))
    cov[:2, :2] = cov_enu_m2[:2, :2]
    cov[2, 2] = half_m**2 / chi2_threshold
    return centre, cov
