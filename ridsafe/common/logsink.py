"""Where cores put what they want logged, without knowing about files.

Every sans-I/O core (sim backend, companion, GCS) takes a ``LogSink`` and calls
``sink.log(topic, t_s, record)`` with a topic from ``ridsafe.common.topics``, the sim time
the record is about, and a JSON-serialisable mapping (numbers, strings, bools, None, lists,
dicts; no numpy scalars or arrays: convert with ``.tolist()`` / ``float()``); a long list
of items may come as ``ItemRows``, which reads and pickles as that list.

The MCAP recorder (``ridsafe.tools.runlog.writer``) is the sink of a real run; tests use
``MemorySink``; ``NullSink`` drops everything; ``TeeSink`` hands each record to several.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, cast, overload

Record = Mapping[str, Any]


def items_of(keys: tuple[str, ...], columns: tuple[list[Any], ...]) -> list[dict[str, Any]]:
    """The items ``ItemRows(keys, columns)`` stands for: item i maps each key to its column's
    i-th value, the keys in order."""
    _check_shape(keys, columns)
    return _items_maker(keys)(columns)


def _check_shape(keys: tuple[str, ...], columns: tuple[list[Any], ...]) -> None:
    """A column per key, all of one length, or ValueError."""
    if len(keys) != len(columns) or len({len(column) for column in columns}) > 1:
        raise ValueError(f"ItemRows: {len(keys)} keys for columns of lengths "
                         f"{[len(column) for column in columns]}")  # fmt: skip


ItemsMaker = Callable[[tuple[list[Any], ...]], list[dict[str, Any]]]


@functools.lru_cache(maxsize=64)
def _items_maker(keys: tuple[str, ...]) -> ItemsMaker:
    """``items_of`` for ``keys``, written out as a dict display per item: a run logs tens of
    thousands of items a second of flight (the sim's receptions, the companions' reports),
    and a display builds each dict in about half the time ``dict(zip(keys, row))`` takes."""
    entries = ", ".join(f"{key!r}: row[{i}]" for i, key in enumerate(keys))
    namespace: dict[str, Any] = {}
    exec(f"def items(columns):\n    return [{{{entries}}} for row in zip(*columns)]", namespace)
    return cast(ItemsMaker, namespace["items"])


class ItemRows(Sequence[dict[str, Any]]):
    """A record's list of items (mappings of the same keys) held as one list per key: built
    from arrays and pickled at a fraction of the cost of thousands of dicts (the sim's
    receptions, a companion's reports). It reads as the list of dicts it stands for, and
    unpickles as that list: a run log's writer, in another process, gets plain data; a sink
    that encodes in the process that logged calls ``plain_record``."""

    __slots__ = ("_columns", "_keys")

    def __init__(self, keys: tuple[str, ...], columns: tuple[list[Any], ...]) -> None:
        _check_shape(keys, columns)
        self._keys, self._columns = keys, columns

    def __len__(self) -> int:
        return len(self._columns[0]) if self._columns else 0

    @overload
    def __getitem__(self, index: int) -> dict[str, Any]: ...
    @overload
    def __getitem__(self, index: slice) -> list[dict[str, Any]]: ...
    def __getitem__(self, index: int | slice) -> dict[str, Any] | list[dict[str, Any]]:
        if isinstance(index, slice):
            return items_of(self._keys, tuple(column[index] for column in self._columns))
        return {key: column[index] for key, column in zip(self._keys, self._columns, strict=True)}

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self.as_list())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and self.as_list() == list(other)

    __hash__ = None  # type: ignore[assignment]

    def __reduce__(self) -> tuple[Any, ...]:
        return (items_of, (self._keys, self._columns))

    def as_list(self) -> list[dict[str, Any]]:
        return items_of(self._keys, self._columns)


def plain_record(record: Record) -> Record:
    """``record`` with each ``ItemRows`` among its values as the list it stands for (the
    record itself when it holds none)."""
    if not any(type(value) is ItemRows for value in record.values()):
        return record
    return {k: v.as_list() if type(v) is ItemRows else v for k, v in record.items()}


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
