"""Is a pad (the take-off point, or the delivery point) clear to take off from or land on?

Take-off and landing are the moments an aircraft cannot dodge: on the pad it cannot leave
sideways, and the autopilot's climb to the take-off altitude and its final landing run are not
the planner's. So the mission holds them while a hazard covers the pad (``pad_clearance_m``
> 0, ``CompanionConfig``):

- an unsafe region (only for a planner that uses regions: the aware one) whose horizontal
  footprint, projected along its velocity over the next ``pad_lookahead_s``, comes within
  ``pad_clearance_m`` of the pad::

      |c_h(t + tau) - pad_h| - sqrt(chi2 lambda_max(P_h)) < pad_clearance_m,  tau in [0, T]

  (``c_h``, ``P_h``: the horizontal part of the region's centre and covariance); a region
  around a radio on the ground (``Region.on_ground``, a ghost's) only where its footprint
  covers the pad (clearance 0): it is no aircraft that the climb or the landing could meet;
- another *airborne* aircraft, as its Remote ID claims it (flagged claims only for a planner
  that trusts them), within ``pad_clearance_m`` horizontally of the pad and below
  ``ceiling_m`` (take-off: climbing through it; landing: lower than the aircraft itself, so
  already on its way down there). An aircraft on the ground (claimed height within
  ``GROUND_HEIGHT_M`` of the pad and slower than ``GROUND_SPEED_M_S``) blocks nothing: it is
  parked on its own pad.

All positions in the companion's local NED frame (metres); ``pad_blocker`` returns what covers
the pad (``"region <id>"`` or ``"aircraft <id>"``) or None.
"""

from __future__ import annotations

import math

import numpy as np

from ridsafe.companion.planner_api import Neighbour, Region, Vec3

__all__ = ["GROUND_HEIGHT_M", "GROUND_SPEED_M_S", "on_ground", "pad_blocker"]

GROUND_HEIGHT_M = 1.0
GROUND_SPEED_M_S = 0.5
_LOOKAHEAD_STEP_S = 1.0


def on_ground(neighbour: Neighbour, ground_down_m: float = 0.0) -> bool:
    """The neighbour claims to stand on the ground (within ``GROUND_HEIGHT_M``, not moving)."""
    height_m = ground_down_m - neighbour.p_ned_m[2]
    return height_m <= GROUND_HEIGHT_M and math.hypot(*neighbour.v_ned_m_s) < GROUND_SPEED_M_S


def _region_near(
    region: Region, pad_ned_m: Vec3, t_s: float, clear_m: float, ahead_s: float
) -> bool:
    cov_h = np.array(region.cov_ned_m2, dtype=np.float64)[:2, :2]
    semi_m = math.sqrt(max(region.chi2_threshold * float(np.linalg.eigvalsh(cov_h)[-1]), 0.0))
    tau = np.arange(0.0, ahead_s + 1e-9, _LOOKAHEAD_STEP_S) + (t_s - region.t_s)
    centre = np.array(region.center_ned_m[:2]) + np.outer(tau, region.v_ned_m_s[:2])
    gap_m = np.hypot(*(centre - np.array(pad_ned_m[:2])).T) - semi_m
    return bool(np.any(gap_m < clear_m))


def pad_blocker(
    pad_ned_m: Vec3,
    t_s: float,
    neighbours: tuple[Neighbour, ...],
    regions: tuple[Region, ...],
    clearance_m: float,
    lookahead_s: float,
    ceiling_m: float,
) -> str | None:
    """What covers the pad (module docstring), or None when it is clear. ``neighbours`` and
    ``regions`` are the ones the planner's policy lets in; ``ceiling_m`` is a height above the
    pad."""
    for region in regions:
        live = region.valid_until_s >= t_s
        clear_m = 0.0 if region.on_ground else clearance_m
        if live and _region_near(region, pad_ned_m, t_s, clear_m, lookahead_s):
            return f"region {region.uas_id}"
    for neighbour in neighbours:
        p = neighbour.p_ned_m
        height_m = pad_ned_m[2] - p[2]
        if on_ground(neighbour, pad_ned_m[2]) or height_m >= ceiling_m:
            continue
        if math.hypot(p[0] - pad_ned_m[0], p[1] - pad_ned_m[1]) < clearance_m:
            return f"aircraft {neighbour.uas_id}"
    return None
