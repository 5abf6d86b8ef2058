"""Reading a run log: every JSON record of an MCAP file, tolerating a cut-off tail.

:func:`read_records` yields ``(topic, t_s, record)`` in file order. A file cut off before
the writer's ``close()`` (a crash, a killed process) yields everything up to its last complete
chunk, with a warning; a file that is not MCAP at all raises :class:`LogReadError`.
:func:`iter_messages` is the raw layer underneath, shared with the part merge. Records are
parsed by ``orjson`` (as the writer encodes them; ``bench/bench_recorder.py`` reads back
twice as fast with it), and by the standard library's parser where ``orjson`` refuses what
it accepts (``NaN``, an integer beyond 64 bits): the same values either way.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import orjson
from mcap.records import Channel, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from ridsafe.common.errors import RidsafeError
from ridsafe.tools.runlog.writer import JSON_ENCODING

__all__ = ["LogReadError", "ReadStatus", "iter_messages", "read_records"]

logger = logging.getLogger(__name__)

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_RECORD_SIZE_LIMIT = 1 << 30


class LogReadError(RidsafeError):
    """A file is not a readable MCAP run log."""


def _parse(data: bytes) -> Any:
    """One record's JSON (module docstring); ValueError if it is not JSON."""
    try:
        return orjson.loads(data)
    except orjson.JSONDecodeError:
        return json.loads(data)


@dataclass
class ReadStatus:
    """What a tolerant read of one file found (filled in while iterating)."""

    messages: int = 0
    complete: bool = False
    error: str | None = None
    metadata: list[Metadata] = field(default_factory=list)


def _check_magic(path: Path) -> None:
    try:
        with open(path, "rb") as stream:
            head = stream.read(len(_MCAP_MAGIC))
    except OSError as exc:
        raise LogReadError(f"{path}: cannot open: {exc.strerror or exc}") from exc
    if head != _MCAP_MAGIC:
        what = "empty" if not head else f"starts with {head!r}"
        raise LogReadError(f"{path}: not an MCAP file ({what})")


def iter_messages(
    path: Path, status: ReadStatus
) -> Iterator[tuple[Channel, Schema | None, Message]]:
    """Every readable message of ``path`` in file order, stopping quietly at a cut-off or
    corrupt tail (then ``status.complete`` stays False and ``status.error`` says why)."""
    _check_magic(path)
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    with open(path, "rb") as stream:
        reader = StreamReader(stream, validate_crcs=True, record_size_limit=_RECORD_SIZE_LIMIT)
        try:
            for record in reader.records:
                if isinstance(record, Message):
                    channel = channels.get(record.channel_id)
                    if channel is None:
                        raise LogReadError(f"message on unknown channel {record.channel_id}")
                    status.messages += 1
                    yield channel, schemas.get(channel.schema_id), record
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Metadata):
                    status.metadata.append(record)
                elif isinstance(record, Footer):
                    status.complete = True  # provisional: the closing magic follows
        except Exception as exc:  # a cut-off tail fails in many ways: stop at any
            status.complete = False
            status.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            logger.warning(
                "%s: unreadable after %d messages (%s); cut off?",
                path,
                status.messages,
                status.error,
            )


def read_records(
    path: str | os.PathLike[str], topics: Collection[str] | None = None
) -> Iterator[tuple[str, float, dict[str, Any]]]:
    """``(topic, t_s, record)`` for every JSON record of ``path`` (only ``topics`` if given),
    in file order. A file cut off before ``close()`` yields what was written up to its last
    complete chunk (with a warning). Raises :class:`LogReadError` for a file that is not MCAP.
    """
    status = ReadStatus()
    for channel, _schema, message in iter_messages(Path(path), status):
        if topics is not None and channel.topic not in topics:
            continue
        if channel.message_encoding != JSON_ENCODING:
            continue
        try:
            record = _parse(message.data)
        except ValueError as exc:
            raise LogReadError(f"{path}: {channel.topic}: record is not JSON: {exc}") from exc
        t_s = record.get("t_s") if isinstance(record, dict) else None
        if not isinstance(t_s, int | float):
            t_s = message.log_time * 1e-9
        yield channel.topic, float(t_s), record
