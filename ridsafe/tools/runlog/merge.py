"""Merging the part logs of a live run (one MCAP file per process) into one run log.

:func:`merge_parts` sorts every readable message of the parts by log time into one file,
de-duplicating channels and the derived ``/foxglove/`` messages several parts wrote alike,
and reports per part how much was readable.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from ridsafe.tools.runlog.foxglove_channels import TOPIC_PREFIX as FOXGLOVE_PREFIX
from ridsafe.tools.runlog.reader import LogReadError, ReadStatus, iter_messages
from ridsafe.tools.runlog.writer import DEFAULT_CHUNK_SIZE, LIBRARY

__all__ = ["MergeReport", "PartReport", "merge_parts"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class PartReport:
    """One part file: how many messages were readable, and whether it was finished."""

    path: Path
    messages: int
    complete: bool
    error: str | None = None


@dataclass(frozen=True)
class MergeReport:
    out: Path
    parts: tuple[PartReport, ...]
    messages: int  # written to ``out``
    duplicates_dropped: int  # identical derived /foxglove/ messages written by several parts

    @property
    def complete(self) -> bool:
        return all(part.complete for part in self.parts)


# (topic, message encoding, schema name, schema encoding, schema data)
_ChannelKey = tuple[str, str, str, str, bytes]


def _channel_key(channel: Channel, schema: Schema | None) -> _ChannelKey:
    if schema is None:
        return (channel.topic, channel.message_encoding, "", "", b"")
    return (channel.topic, channel.message_encoding, schema.name, schema.encoding, schema.data)


def _read_part(
    path: Path,
) -> tuple[PartReport, list[tuple[int, _ChannelKey, Message]], ReadStatus]:
    status = ReadStatus()
    entries: list[tuple[int, _ChannelKey, Message]] = []
    try:
        for channel, schema, message in iter_messages(path, status):
            entries.append((message.log_time, _channel_key(channel, schema), message))
    except LogReadError as exc:
        status.error = str(exc)
        logger.warning("%s", exc)
    report = PartReport(path, status.messages, status.complete, status.error)
    return report, entries, status


def merge_parts(
    parts: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
) -> MergeReport:
    """Merge the part files of a live run into ``out``, sorted by log time.

    Channels are de-duplicated by topic, encoding and schema; messages with equal log time
    keep the order of ``parts`` and, within a part, the file order. Truncated or unreadable
    parts contribute what is readable (reported per part). Identical derived ``/foxglove/``
    messages (same channel, time and bytes, e.g. each part's frame transform) are kept once;
    every other readable message is written. ``out`` is written to a temporary file first
    and renamed, so it is never half-written.
    """
    part_paths = [Path(p) for p in parts]
    out_path = Path(out)
    if any(p.resolve() == out_path.resolve() for p in part_paths):
        raise ValueError(f"merge_parts: the output {out_path} is also one of the parts")
    reports: list[PartReport] = []
    entries: list[tuple[int, _ChannelKey, Message]] = []
    metadata: list[tuple[Path, Metadata]] = []
    for path in part_paths:
        report, part_entries, status = _read_part(path)
        reports.append(report)
        entries.extend(part_entries)
        metadata.extend((path, m) for m in status.metadata)
    entries.sort(key=lambda entry: entry[0])  # stable: part order, then file order
    tmp = out_path.with_name(out_path.name + ".tmp")
    written, dropped = _write_merged(tmp, entries, metadata, chunk_size)
    os.replace(tmp, out_path)
    return MergeReport(out_path, tuple(reports), written, dropped)


def _write_merged(
    path: Path,
    entries: list[tuple[int, _ChannelKey, Message]],
    metadata: list[tuple[Path, Metadata]],
    chunk_size: int,
) -> tuple[int, int]:
    schema_ids: dict[tuple[str, str, bytes], int] = {}
    channel_ids: dict[_ChannelKey, int] = {}
    seen_derived: set[tuple[_ChannelKey, int, bytes]] = set()
    written = dropped = 0
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as stream:
        writer = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile="", library=LIBRARY)
        for log_time, key, message in entries:
            topic, message_encoding, schema_name, schema_encoding, schema_data = key
            if topic.startswith(FOXGLOVE_PREFIX):
                fingerprint = (key, log_time, message.data)
                if fingerprint in seen_derived:
                    dropped += 1
                    continue
                seen_derived.add(fingerprint)
            channel_id = channel_ids.get(key)
            if channel_id is None:
                schema_id = 0
                if schema_name or schema_encoding:
                    schema_key = (schema_name, schema_encoding, schema_data)
                    if schema_key not in schema_ids:
                        schema_ids[schema_key] = writer.register_schema(*schema_key)
                    schema_id = schema_ids[schema_key]
                channel_id = writer.register_channel(topic, message_encoding, schema_id)
                channel_ids[key] = channel_id
            writer.add_message(
                channel_id, log_time, message.data, message.publish_time, message.sequence
            )
            written += 1
        for part, record in metadata:
            writer.add_metadata(record.name, {**record.metadata, "part": part.name})
        writer.finish()
    return written, dropped
