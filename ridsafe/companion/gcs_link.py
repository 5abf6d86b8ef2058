"""What the companion takes from the ground station: unsafe regions and spoofing alerts.

``GcsWatch`` hands RIDSAFE_UNSAFE_REGION and RIDSAFE_SPOOF_ALERT to the ``RegionStore`` and
logs what changed; the GCS counts as seen from its first message and as lost after
``gcs_timeout_s`` of silence (seen again with its next message). Regions past their validity
are dropped by ``watch``.
"""

from __future__ import annotations

from dataclasses import dataclass

from ridsafe.common import messages as m
from ridsafe.common.codec import Received
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.events import CompanionLog
from ridsafe.companion.regions import RegionStore
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = ["GcsCounters", "GcsWatch"]

_QUIET_REGION_OUTCOMES = frozenset({"replaced", "stale"})


@dataclass
class GcsCounters:
    unused_gcs: int = 0


class GcsWatch:
    """Regions and alerts from the GCS, and whether it is there (see the module docstring)."""

    def __init__(self, config: CompanionConfig, own: OwnTelemetry, log: CompanionLog) -> None:
        self.config = config
        self.own = own
        self.log = log
        self.regions = RegionStore()
        self.counters = GcsCounters()
        self.seen_s: float | None = None
        self.lost = False

    def on_message(self, now_s: float, received: Received) -> None:
        if self.seen_s is None or self.lost:
            self.log.event(now_s, "gcs_seen", f"system {received.src_system}")
            self.lost = False
        self.seen_s = now_s
        msg = received.message
        if isinstance(msg, m.UnsafeRegionMsg):
            outcome = self.regions.on_region(self.own.sim_time(now_s), msg)
            if outcome not in _QUIET_REGION_OUTCOMES:
                self.log.event(now_s, "region", f"{msg.uas_id}: {outcome}", uas_id=msg.uas_id)
        elif isinstance(msg, m.SpoofAlert):
            if self.regions.on_alert(msg):
                state = "raised" if self.regions.is_flagged(msg.uas_id) else "cleared"
                self.log.event(now_s, "alert", f"{msg.uas_id}: {state}", uas_id=msg.uas_id)
        elif not isinstance(msg, m.Heartbeat):
            self.counters.unused_gcs += 1

    def watch(self, now_s: float) -> None:
        seen = self.seen_s
        if seen is not None and not self.lost and now_s - seen > self.config.gcs_timeout_s:
            self.lost = True
            self.log.event(now_s, "gcs_lost", f"nothing from the GCS for {now_s - seen:.1f} s")
        for uas_id in self.regions.expire(self.own.sim_time(now_s)):
            self.log.event(now_s, "region", f"{uas_id}: expired", uas_id=uas_id)
