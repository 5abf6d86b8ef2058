"""Where cores put what they want logged, without knowing about files.

Every sans-I/O core (sim backend, companion, GCS) takes a ``LogSink`` and calls
``sink.log(topic, t_s, record)`` with a topic from ``ridsafe.common.topics``, the sim time
the record is about, and a JSON-serialisable mapping (numbers, strings, bools, None, lists,
dicts; no numpy scalars or arrays: convert with ``.tolist()`` / ``float()``).

The MCAP recorder (``ridsafe.tools.runlog.writer``) is the sink of a real run; tests use
``MemorySink``; ``NullSink`` drops everything; ``TeeSink`` hands each record to several.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

Record = Mapping[str, Any]


class LogSink(Protocol):
    def log(self, topic: str, t_s: float, record: Record) -> None: ...


class NullSink:
    def log(self, topic: str, t_s: float, record: Record) -> None:
        return None


@dataclass(frozen=True)
class TeeSink:
    """Every record to each of ``sinks`` in turn (a run's log and its live view)."""

    sinks: tuple[LogSink, ...]

    def log(self, topic: str, t_s: float, record: Record) -> None:
        for sink in self.sinks:
            sink.log(topic, t_s, record)


@dataclass
class MemorySink:
    """Keeps every record in order: ``records`` is a list of (topic, t_s, record)."""

    records: list[tuple[str, float, Record]] = field(default_factory=list)

    def log(self, topic: str, t_s: float, record: Record) -> None:
        self.records.append((topic, t_s, record))

    def on(self, topic: str) -> list[tuple[float, Record]]:
        return [(t, r) for name, t, r in self.records if name == topic]
