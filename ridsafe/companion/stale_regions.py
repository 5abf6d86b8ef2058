r"""What the planner avoids when the GCS stops refreshing a region: the last one, grown.

The GCS sends each spoofer's unsafe region every cycle with a short validity, and a DELETED
message when it drops the track. A region whose validity ends with neither a newer one nor a
DELETED means the GCS, or the link to it, is lost; the spoofer is still somewhere. With
``stale_region_hold_s > 0`` the companion keeps that last region for the planner for up to
``stale_region_hold_s`` after its validity ended, moved along its velocity and inflated by a
random walk of the position:

    c(t) = c + v (t - t_s),        P(t) = P + q (t - t_s) I_3,

``t_s`` the estimate's time, ``q = stale_region_growth_m2_s`` (m^2/s, the position diffusion
the tracker's process noise implies; 25 m^2/s grows the 1-sigma radius by about 39 m in the
first minute) and ``chi2_threshold`` unchanged, so the region keeps its containment
probability under that model while it grows. After the hold, or at a DELETED, it is gone. A
fresh region from the GCS replaces it at once. With ``stale_region_hold_s = 0`` (the
default) a region is dropped when its validity ends, as before.
"""

from __future__ import annotations

from ridsafe.common import messages as m
from ridsafe.companion.planner_api import Mat3, Region
from ridsafe.companion.regions import ToLocal, cov_matrix

__all__ = ["held_regions", "inflated"]


def inflated(msg: m.UnsafeRegionMsg, now_s: float, growth_m2_s: float, to_local: ToLocal) -> Region:
    """The region of ``msg`` at ``now_s`` by the module docstring's rule, in local NED."""
    dt_s = max(0.0, now_s - msg.t_s)
    cx, cy, cz = to_local(msg.center_lat_deg, msg.center_lon_deg, msg.center_alt_m)
    vx, vy, vz = msg.v_ned_m_s
    grow = growth_m2_s * dt_s
    p = cov_matrix(msg.cov_ned_m2)
    cov: Mat3 = (
        (p[0][0] + grow, p[0][1], p[0][2]),
        (p[1][0], p[1][1] + grow, p[1][2]),
        (p[2][0], p[2][1], p[2][2] + grow),
    )
    return Region(
        uas_id=msg.uas_id,
        center_ned_m=(cx + vx * dt_s, cy + vy * dt_s, cz + vz * dt_s),
        cov_ned_m2=cov,
        chi2_threshold=msg.chi2_threshold,
        v_ned_m_s=msg.v_ned_m_s,
        t_s=now_s,
        valid_until_s=now_s,
        on_ground=bool(msg.flags & m.RegionFlags.ON_GROUND),
    )


def held_regions(
    expired_last: dict[str, m.UnsafeRegionMsg],
    now_s: float,
    hold_s: float,
    growth_m2_s: float,
    to_local: ToLocal,
) -> tuple[Region, ...]:
    """The expired regions still held at ``now_s``, inflated; the ones past the hold are
    removed from ``expired_last``."""
    if hold_s <= 0.0:
        expired_last.clear()
        return ()
    for uas_id in [u for u, msg in expired_last.items() if now_s - msg.valid_until_s > hold_s]:
        del expired_last[uas_id]
    return tuple(inflated(msg, now_s, growth_m2_s, to_local) for msg in expired_last.values())
