"""Unsafe regions and spoofing alerts received from the GCS, kept for the planner.

Regions (RIDSAFE_UNSAFE_REGION) are kept by spoofer id (``uas_id``): a newer estimate
replaces the older one, an older or repeated one is ignored, one with the DELETED flag
removes the id, and one past its ``valid_until_s`` expires (times on the clock the GCS and
the sim share, see ``Companion``). Alerts (RIDSAFE_SPOOF_ALERT) raise or clear a flag per id.

For the planner, a region's centre (WGS-84) becomes the aircraft's local NED frame through
``to_local`` (the companion's geodetic -> local NED about its home); its covariance, in NED
axes already, is unpacked from MAVLink's upper triangle (xx, xy, xz, yy, yz, zz) into a
symmetric 3 x 3 matrix. The NED axes at the GCS origin and at a home a few km away differ by
well under 0.1 degree, which the covariance does not resolve.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import asdict, dataclass

from ridsafe.common import messages as m
from ridsafe.common.messages import AlertState, RegionFlags
from ridsafe.companion.planner_api import Mat3, Region, Vec3

__all__ = ["RegionCounters", "RegionStore", "ToLocal", "cov_matrix"]

logger = logging.getLogger(__name__)

#: (lat_deg, lon_deg, alt_m) -> local NED metres.
ToLocal = Callable[[float, float, float], Vec3]


@dataclass
class RegionCounters:
    received: int = 0
    replaced: int = 0
    stale: int = 0  # older than (or as old as) the one kept
    deleted: int = 0
    expired: int = 0
    expired_on_arrival: int = 0
    alerts_raised: int = 0
    alerts_cleared: int = 0


def cov_matrix(upper: tuple[float, float, float, float, float, float]) -> Mat3:
    """MAVLink's (xx, xy, xz, yy, yz, zz) -> the symmetric 3 x 3 covariance."""
    xx, xy, xz, yy, yz, zz = upper
    return ((xx, xy, xz), (xy, yy, yz), (xz, yz, zz))


class RegionStore:
    """The live unsafe regions by uas_id, and the ids the GCS has raised an alert for."""

    def __init__(self) -> None:
        self.counters = RegionCounters()
        self._regions: dict[str, m.UnsafeRegionMsg] = {}
        self._alerts: dict[str, m.SpoofAlert] = {}
        #: The last region of each id whose validity ended without a newer one or a DELETED
        #: (the GCS stopped refreshing it); ``stale_regions`` may keep it, inflated.
        self.expired_last: dict[str, m.UnsafeRegionMsg] = {}

    # -- input ------------------------------------------------------------------------------

    def on_region(self, now_s: float, msg: m.UnsafeRegionMsg) -> str:
        """Apply one region message; returns what happened (for the event log)."""
        self.counters.received += 1
        kept = self._regions.get(msg.uas_id)
        if kept is not None and msg.t_s <= kept.t_s:
            self.counters.stale += 1
            return "stale"
        if msg.flags & RegionFlags.DELETED:
            self.expired_last.pop(msg.uas_id, None)
            if self._regions.pop(msg.uas_id, None) is not None:
                self.counters.deleted += 1
                return "deleted"
            return "deleted_unknown"
        if msg.valid_until_s < now_s:
            self.counters.expired_on_arrival += 1
            return "expired_on_arrival"
        if kept is not None:
            self.counters.replaced += 1
        self._regions[msg.uas_id] = msg
        self.expired_last.pop(msg.uas_id, None)
        return "replaced" if kept is not None else "new"

    def on_alert(self, msg: m.SpoofAlert) -> bool:
        """Apply one alert; True if it changed whether the id is flagged."""
        kept = self._alerts.get(msg.uas_id)
        if kept is not None and msg.t_s < kept.t_s:
            return False  # an older alert overtaken by a newer one
        was = self.is_flagged(msg.uas_id)
        self._alerts[msg.uas_id] = msg
        now = self.is_flagged(msg.uas_id)
        if now and not was:
            self.counters.alerts_raised += 1
        elif was and not now:
            self.counters.alerts_cleared += 1
        return now != was

    # -- output -----------------------------------------------------------------------------

    def is_flagged(self, uas_id: str) -> bool:
        alert = self._alerts.get(uas_id)
        return alert is not None and alert.state == AlertState.RAISED

    @property
    def flagged(self) -> frozenset[str]:
        return frozenset(uas for uas in self._alerts if self.is_flagged(uas))

    def expire(self, now_s: float) -> list[str]:
        """Drop regions whose validity ended before ``now_s``; their ids."""
        gone = [uas for uas, r in self._regions.items() if r.valid_until_s < now_s]
        for uas in gone:
            self.expired_last[uas] = self._regions.pop(uas)
            self.counters.expired += 1
            logger.info("unsafe region of %s expired", uas)
        return gone

    def live(self, now_s: float) -> list[m.UnsafeRegionMsg]:
        """The regions still valid at ``now_s`` (expired ones are dropped first)."""
        self.expire(now_s)
        return list(self._regions.values())

    def regions(self, now_s: float, to_local: ToLocal) -> tuple[Region, ...]:
        """The live regions in the planner's local NED frame."""
        return tuple(_to_region(r, to_local) for r in self.live(now_s))

    def counters_dict(self) -> dict[str, int]:
        return dict(asdict(self.counters))


def _to_region(msg: m.UnsafeRegionMsg, to_local: ToLocal) -> Region:
    return Region(
        uas_id=msg.uas_id,
        center_ned_m=to_local(msg.center_lat_deg, msg.center_lon_deg, msg.center_alt_m),
        cov_ned_m2=cov_matrix(msg.cov_ned_m2),
        chi2_threshold=msg.chi2_threshold,
        v_ned_m_s=msg.v_ned_m_s,
        t_s=msg.t_s,
        valid_until_s=msg.valid_until_s,
        on_ground=bool(msg.flags & RegionFlags.ON_GROUND),
    )
