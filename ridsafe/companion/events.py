"""The companion's event log: one line to ``logging`` and one ``/companion/events`` record
per event (link seen or lost, mission phase, region, planner error...), stamped on the
autopilot's clock."""

from __future__ import annotations

import logging

from ridsafe.common import topics
from ridsafe.common.logsink import LogSink
from ridsafe.companion.telemetry import OwnTelemetry

logger = logging.getLogger("ridsafe.companion.companion")


class CompanionLog:
    """Events and records of companion ``sysid``; times go through ``own.sim_time``."""

    def __init__(self, sysid: int, sink: LogSink, own: OwnTelemetry) -> None:
        self.sysid = sysid
        self.sink = sink
        self.own = own

    def event(self, now_s: float, event: str, detail: str, **extra: object) -> None:
        logger.info("companion %d: %s: %s", self.sysid, event, detail)
        record = {"sysid": self.sysid, "event": event, "detail": detail, **extra}
        self.sink.log(topics.COMPANION_EVENTS, self.own.sim_time(now_s), record)

    def record(self, topic: str, now_s: float, record: dict[str, object]) -> None:
        self.sink.log(topic, self.own.sim_time(now_s), record)
