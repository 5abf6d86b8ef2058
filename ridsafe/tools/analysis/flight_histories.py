"""What each aircraft's companion said it was doing, from the log: its mission phases
(``phase`` events of ``/companion/events``) and its planner's statuses (``/companion/decisions``),
as time-ordered histories, and the part of a delivery flight each phase belongs to."""

from __future__ import annotations

import bisect
import enum
from collections.abc import Mapping

from ridsafe.common import topics
from ridsafe.tools.analysis.run_arrays import RunLog
from ridsafe.tools.runlog.reader import read_records

__all__ = ["History", "Stage", "flight_histories", "stage_of", "value_at"]


class Stage(enum.Enum):
    """The part of a delivery flight a mission phase belongs to (``companion/mission.Phase``)."""

    TAKE_OFF = "take-off and climb"
    CRUISE = "cruise"
    ARRIVAL = "arrival and landing"
    UNKNOWN = "unknown"


_STAGES: Mapping[str, Stage] = {
    "wait_departure": Stage.TAKE_OFF,
    "set_guided": Stage.TAKE_OFF,
    "arm": Stage.TAKE_OFF,
    "takeoff": Stage.TAKE_OFF,
    "climb": Stage.TAKE_OFF,
    "cruise": Stage.CRUISE,
    "arrived": Stage.ARRIVAL,
    "descend": Stage.ARRIVAL,
    "hover": Stage.ARRIVAL,
    "land": Stage.ARRIVAL,
    "done": Stage.ARRIVAL,
}


def stage_of(phase: str | None) -> Stage:
    """The :class:`Stage` of a mission phase's value (``Stage.UNKNOWN`` for none or another)."""
    return _STAGES.get(phase or "", Stage.UNKNOWN)


History = dict[int, list[tuple[float, str]]]


def flight_histories(run: RunLog, sysids: set[int]) -> tuple[History, History]:
    """(phases, planner statuses) of the aircraft ``sysids``: sysid -> [(time, value)] from
    the companions' ``phase`` events and planner decisions, in time order."""
    phases: History = {}
    statuses: History = {}
    if not run.path.exists() or not sysids:
        return phases, statuses
    wanted = (topics.COMPANION_EVENTS, topics.DECISIONS)
    for topic, t_s, record in read_records(run.path, topics=wanted):
        sysid = int(record.get("sysid", 0))
        if sysid not in sysids:
            continue
        if topic == topics.DECISIONS and record.get("status") is not None:
            statuses.setdefault(sysid, []).append((t_s, str(record["status"])))
        elif record.get("event") == "phase" and record.get("to") is not None:
            phases.setdefault(sysid, []).append((t_s, str(record["to"])))
    return (
        {k: sorted(v) for k, v in phases.items()},
        {k: sorted(v) for k, v in statuses.items()},
    )


def value_at(history: list[tuple[float, str]], t_s: float) -> str | None:
    """The last value of ``history`` at or before ``t_s``."""
    k = bisect.bisect_right(history, t_s, key=lambda item: item[0])
    return history[k - 1][1] if k else None
