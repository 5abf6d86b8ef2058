"""The run log: an MCAP file of JSON records, written by one recorder, read back by metrics.

This is the only module that imports ``mcap``.

Writing. :class:`McapRecorder` is the ``LogSink`` of a real run. Each topic gets one channel
(message encoding ``json``, schema encoding ``jsonschema``, schema ``topics.schema(topic)``;
a topic missing from ``topics.TOPICS`` gets a permissive schema and one warning). Log and
publish time are the sim time in integer nanoseconds, and the record is stored with ``t_s``
added as its first field (unless the writer put one there itself). Chunks are small
(256 KiB, zstd) and the recorder also closes the open chunk every ``flush_every_s`` of sim
time, so a crash loses at most one chunk: a file cut off before ``close()`` stays readable
up to its last complete chunk with the streaming reader used by :func:`read_records`.

Non-finite numbers. JSON has no NaN or infinity, and a run must not die because one estimate
went NaN, so the recorder writes them as ``null``, counts them per (topic, field path)
(``nonfinite_counts``, e.g. ``{"/truth/vehicles:p_enu_m[][]": 3}``), warns once per field
path, and stores the counts in the file's ``ridsafe.recorder`` metadata record on close.
Readers see ``None``; ``numpy.array(values, dtype=float)`` turns it back into NaN. A value
JSON cannot encode at all (a set, an object) raises :class:`RecorderError` naming the topic
and field. numpy scalars and arrays are accepted and converted (``.item()``/``.tolist()``).

Foxglove. The recorder also derives typed Foxglove channels (``ridsafe.tools.foxglove``):
the aircraft scene, the unsafe-region ellipsoids, a 1 Hz ``LocationFix`` per vehicle and one
"world" -> "enu" ``FrameTransform``. The geodetic conversion needs the scenario origin: the
recorder takes it from the ``/run/meta`` record (``scenario.scenario.origin``) or from its
``origin`` argument (for a process of a live run that does not log ``/run/meta``).

Reading and merging. :func:`read_records` yields ``(topic, t_s, record)`` in file order and
tolerates a cut-off tail. :func:`merge_parts` merges the part files of a live run (one per
process) into one file sorted by log time, keeping every readable message.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
from mcap.records import Channel, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from ridsafe.common import topics
from ridsafe.common.errors import RidsafeError
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import Record
from ridsafe.tools import foxglove

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_FLUSH_EVERY_S",
    "LogReadError",
    "McapRecorder",
    "MergeReport",
    "PartReport",
    "RecorderError",
    "merge_parts",
    "read_records",
]

logger = logging.getLogger(__name__)

DEFAULT_CHUNK_SIZE = 256 * 1024
DEFAULT_FLUSH_EVERY_S = 5.0
LOCATION_FIX_PERIOD_S = 1.0
METADATA_NAME = "ridsafe.recorder"
FOXGLOVE_PREFIX = "/foxglove/"
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_JSON = "json"
_JSONSCHEMA = "jsonschema"
_LIBRARY = "ridsafe.tools.recorder (mcap-python)"
_RECORD_SIZE_LIMIT = 1 << 30


class RecorderError(RidsafeError):
    """The recorder cannot write what it was given (or was used after ``close()``)."""


class LogReadError(RidsafeError):
    """A file is not a readable MCAP run log."""


# --------------------------------------------------------------------------------------------
# JSON encoding


def _to_plain(value: Any) -> Any:
    """``default`` hook of the encoder: numpy and non-dict mappings; anything else fails."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, tuple):
        return list(value)
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


# One encoder, built once: json.dumps with non-default options builds a new one per call.
_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_to_plain)


def _sanitise(value: Any, path: str, found: list[str]) -> Any:
    """A copy of ``value`` with non-finite floats replaced by None; their paths go to found.

    Paths name fields with dots and list levels with ``[]``: ``items[].rssi_dbm``.
    """
    if isinstance(value, float | np.floating):
        if math.isfinite(value):
            return value
        found.append(path)
        return None
    if isinstance(value, Mapping):
        return {k: _sanitise(v, f"{path}.{k}" if path else str(k), found) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return [_sanitise(v, f"{path}[]", found) for v in value]
    return value


def _unserialisable_path(value: Any, path: str = "") -> str:
    """The path of the first value JSON cannot encode (for error messages), or ""."""
    children: list[tuple[str, Any]]
    if isinstance(value, Mapping):
        bad_keys = [k for k in value if not isinstance(k, _JSON_KEYS) and k is not None]
        if bad_keys:
            return f"{path}{{key {bad_keys[0]!r}}}"
        children = [(f"{path}.{k}" if path else str(k), v) for k, v in value.items()]
    elif isinstance(value, list | tuple):
        children = [(f"{path}[{k}]", v) for k, v in enumerate(value)]
    elif value is None or isinstance(value, _JSON_SCALARS):
        return ""
    else:
        return f"{path or '<record>'} ({type(value).__name__})"
    for child_path, child in children:
        found = _unserialisable_path(child, child_path)
        if found:
            return found
    return ""


_JSON_KEYS = (str, int, float, bool)
_JSON_SCALARS = (str, int, float, np.generic, np.ndarray)


# --------------------------------------------------------------------------------------------
# Writing


class McapRecorder:
    """Writes one process's log records to an MCAP file (see the module docstring).

    ``chunk_size``: bytes of uncompressed records per chunk (what a crash can lose at most,
    together with ``flush_every_s``: the open chunk is closed whenever sim time has advanced
    that far since the last flush; None: only when full). ``foxglove``: derive the Foxglove
    channels. ``origin``: the scenario origin for the LocationFix channels when this process
    does not log ``/run/meta``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_every_s: float | None = DEFAULT_FLUSH_EVERY_S,
        foxglove: bool = True,
        origin: GeodeticOrigin | None = None,
    ) -> None:
        if chunk_size <= 0:
            raise ValueError(f"chunk_size must be > 0, got {chunk_size}")
        if flush_every_s is not None and not flush_every_s > 0.0:
            raise ValueError(f"flush_every_s must be > 0 or None, got {flush_every_s}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = _WriteThrough(self.path)
        self._writer = Writer(self._stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library=_LIBRARY)
        self._closed = False
        self._channel_ids: dict[str, int] = {}
        self._schema_ids: dict[str, int] = {}
        self._warned: set[str] = set()
        self._nonfinite: dict[str, int] = {}
        self.message_count = 0
        self._flush_every_s = flush_every_s
        self._next_flush_s = flush_every_s if flush_every_s is not None else math.inf
        self._origin = origin
        self._tf_written = False
        self._next_fix_s = 0.0
        self._hooks: dict[str, Callable[[float, Record], None]] = {topics.RUN_META: self._on_meta}
        if foxglove:
            self._hooks[topics.TRUTH] = self._on_truth
            self._hooks[topics.REGIONS] = self._on_region

    # -- LogSink ------------------------------------------------------------------------------

    def log(self, topic: str, t_s: float, record: Record) -> None:
        """Write ``record`` on ``topic`` at sim time ``t_s`` (s, finite, >= 0)."""
        if self._closed:
            raise RecorderError(f"{topic}: log() after close() of {self.path}")
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._open_topic(topic, record)
        log_time = _log_time_ns(topic, t_s)
        data = self._encode(topic, t_s, record)
        self._writer.add_message(channel_id, log_time, data, log_time)
        self.message_count += 1
        hook = self._hooks.get(topic)
        if hook is not None:
            self._run_hook(topic, hook, t_s, record)
        if t_s >= self._next_flush_s:
            self.flush()
            assert self._flush_every_s is not None
            self._next_flush_s = t_s + self._flush_every_s

    @property
    def nonfinite_counts(self) -> Mapping[str, int]:
        """``"topic:field path"`` -> how many non-finite numbers were written as null."""
        return dict(self._nonfinite)

    def flush(self) -> None:
        """Close the open chunk and push everything written so far to the file."""
        if self._closed:
            return
        # Writer.flush (mcap-python 1.6 has it) closes the open chunk; without it, chunks
        # reach the file only when full.
        flush = getattr(self._writer, "flush", None)
        if flush is not None:
            flush()
        self._stream.flush()

    def close(self) -> None:
        """Finish the file (summary, footer). Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            counts = json.dumps(self._nonfinite, sort_keys=True)
            self._writer.add_metadata(
                METADATA_NAME, {"messages": str(self.message_count), "nonfinite_nulled": counts}
            )
            self._writer.finish()
        finally:
            self._stream.close()

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- channels and encoding ----------------------------------------------------------------

    def _open_topic(self, topic: str, record: Record) -> int:
        if topic in topics.TOPICS:
            schema = topics.schema(topic)
            missing = [name for name in schema["required"] if name not in record]
            if missing:
                logger.warning("%s: first record lacks required fields %s", topic, missing)
        else:
            logger.warning("%s: not in ridsafe.common.topics.TOPICS; permissive schema", topic)
            schema = {"title": topic, "type": "object"}
        return self._register(topic, topic, schema)

    def _register(self, topic: str, schema_name: str, schema: Mapping[str, Any]) -> int:
        schema_id = self._schema_ids.get(schema_name)
        if schema_id is None:
            data = json.dumps(schema, separators=(",", ":")).encode()
            schema_id = self._writer.register_schema(schema_name, _JSONSCHEMA, data)
            self._schema_ids[schema_name] = schema_id
        channel_id: int = self._writer.register_channel(topic, _JSON, schema_id)
        self._channel_ids[topic] = channel_id
        return channel_id

    def _encode(self, topic: str, t_s: float, record: Record) -> bytes:
        try:
            body = _ENCODER.encode(record)
        except ValueError:  # non-finite float (allow_nan=False)
            body = _ENCODER.encode(self._nulled(topic, record))
        except TypeError as exc:
            where = _unserialisable_path(record)
            raise RecorderError(f"{topic}: field {where} cannot be written as JSON") from exc
        if "t_s" in record:
            return body.encode()
        head = '{"t_s":' + repr(float(t_s))
        return (head + "}" if body == "{}" else head + "," + body[1:]).encode()

    def _nulled(self, topic: str, record: Record) -> Any:
        found: list[str] = []
        clean = _sanitise(record, "", found)
        for path in found:
            key = f"{topic}:{path}"
            if key not in self._nonfinite:
                logger.warning("%s: non-finite number written as null (counted)", key)
                self._nonfinite[key] = 0
            self._nonfinite[key] += 1
        return clean

    # -- Foxglove channels ------------------------------------------------------------------------

    def _run_hook(
        self, topic: str, hook: Callable[[float, Record], None], t_s: float, record: Record
    ) -> None:
        try:
            hook(t_s, record)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            if topic not in self._warned:
                self._warned.add(topic)
                logger.warning("%s: no Foxglove view for this record (%r); skipped", topic, exc)

    def _write_derived(self, topic: str, schema_name: str, t_s: float, message: Any) -> None:
        """Write a Foxglove message (a dict, or JSON text already encoded)."""
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._register(topic, schema_name, foxglove.SCHEMAS[schema_name])
        log_time = _log_time_ns(topic, t_s)
        text = message if isinstance(message, str) else _ENCODER.encode(message)
        self._writer.add_message(channel_id, log_time, text.encode(), log_time)
        self.message_count += 1

    def _ensure_tf(self) -> None:
        if not self._tf_written:
            self._tf_written = True
            tf = foxglove.world_to_enu_transform(0.0)
            self._write_derived(foxglove.TF_TOPIC, foxglove.FRAME_TRANSFORM, 0.0, tf)

    def _on_meta(self, t_s: float, record: Record) -> None:
        if self._origin is None:
            self._origin = origin_from_meta(record)

    def _on_truth(self, t_s: float, record: Record) -> None:
        self._ensure_tf()
        scene = foxglove.aircraft_scene(t_s, record)
        self._write_derived(foxglove.AIRCRAFT_TOPIC, foxglove.SCENE_UPDATE, t_s, scene)
        if t_s < self._next_fix_s:
            return
        self._next_fix_s = (math.floor(t_s / LOCATION_FIX_PERIOD_S) + 1) * LOCATION_FIX_PERIOD_S
        if self._origin is None:
            if "origin" not in self._warned:
                self._warned.add("origin")
                logger.warning("no scenario origin yet (/run/meta): LocationFix channels skipped")
            return
        for sysid, fix in foxglove.location_fixes(t_s, record, self._origin):
            topic = foxglove.location_topic(sysid)
            self._write_derived(topic, foxglove.LOCATION_FIX, t_s, fix)

    def _on_region(self, t_s: float, record: Record) -> None:
        self._ensure_tf()
        scene = foxglove.regions_scene(t_s, record)
        self._write_derived(foxglove.REGIONS_TOPIC, foxglove.SCENE_UPDATE, t_s, scene)


class _WriteThrough:
    """An unbuffered output file for the mcap writer.

    The writer keeps the open chunk in memory and writes whole records; a buffered file
    would hold a finished chunk (and even the header) in user space, where a crash loses it.
    (Not an ``io.RawIOBase``: the writer would wrap one in a ``BufferedWriter``.)
    """

    def __init__(self, path: Path) -> None:
        self._file: IO[bytes] = open(path, "wb", buffering=0)  # noqa: SIM115 (close())

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            written = self._file.write(view)
            view = view[written:]
        return len(data)

    def tell(self) -> int:
        return self._file.tell()

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def _log_time_ns(topic: str, t_s: float) -> int:
    if not 0.0 <= t_s < math.inf:
        raise RecorderError(f"{topic}: sim time must be finite and >= 0, got {t_s!r}")
    return round(t_s * 1e9)


def origin_from_meta(meta: Mapping[str, Any]) -> GeodeticOrigin | None:
    """The scenario origin of a ``/run/meta`` record (``scenario.scenario.origin``, or
    ``scenario.origin``), or None when it has none."""
    scenario = meta.get("scenario")
    if not isinstance(scenario, Mapping):
        return None
    inner = scenario.get("scenario")
    origin = (inner if isinstance(inner, Mapping) else scenario).get("origin")
    if not isinstance(origin, Mapping):
        return None
    return GeodeticOrigin(
        float(origin["lat_deg"]), float(origin["lon_deg"]), float(origin.get("alt_m", 0.0))
    )


# --------------------------------------------------------------------------------------------
# Reading


@dataclass
class _ReadStatus:
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


def _iter_raw(path: Path, status: _ReadStatus) -> Iterator[tuple[Channel, Schema | None, Message]]:
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
    status = _ReadStatus()
    for channel, _schema, message in _iter_raw(Path(path), status):
        if topics is not None and channel.topic not in topics:
            continue
        if channel.message_encoding != _JSON:
            continue
        try:
            record = json.loads(message.data)
        except ValueError as exc:
            raise LogReadError(f"{path}: {channel.topic}: record is not JSON: {exc}") from exc
        t_s = record.get("t_s") if isinstance(record, dict) else None
        if not isinstance(t_s, int | float):
            t_s = message.log_time * 1e-9
        yield channel.topic, float(t_s), record


# --------------------------------------------------------------------------------------------
# Merging the parts of a live run


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
) -> tuple[PartReport, list[tuple[int, _ChannelKey, Message]], _ReadStatus]:
    status = _ReadStatus()
    entries: list[tuple[int, _ChannelKey, Message]] = []
    try:
        for channel, schema, message in _iter_raw(path, status):
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
        writer.start(profile="", library=_LIBRARY)
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
