"""Writing a run log: one MCAP file of JSON records per process, plus derived channels.

The run log's side of ``mcap``: this module, the reader and the part merge are the only ones
that import it.

:class:`McapRecorder` is the ``LogSink`` of a real run. Each topic gets one channel (message
encoding ``json``, schema encoding ``jsonschema``, schema ``topics.schema(topic)``; a topic
missing from ``topics.TOPICS`` gets a permissive schema and one warning). Log and publish time
are the sim time in integer nanoseconds, and the record is stored with ``t_s`` added as its
first field (unless the writer put one there itself). Chunks are small (256 KiB, zstd) and the
recorder also closes the open chunk every ``flush_every_s`` of sim time, so a crash loses at
most one chunk: a file cut off before ``close()`` stays readable up to its last complete chunk
(``ridsafe.tools.runlog.reader``).

Non-finite numbers. JSON has no NaN or infinity, and a run must not die because one estimate
went NaN, so the recorder writes them as ``null``, counts them per (topic, field path)
(``nonfinite_counts``, e.g. ``{"/truth/vehicles:p_enu_m[][]": 3}``), warns once per field
path, and stores the counts in the file's ``ridsafe.recorder`` metadata record on close.
Readers see ``None``; ``numpy.array(values, dtype=float)`` turns it back into NaN. A value
JSON cannot encode at all (a set, an object) raises :class:`RecorderError` naming the topic
and field. numpy scalars and arrays are accepted and converted (``.item()``/``.tolist()``).

Encoding speed. Records, and the plug-ins' messages, are encoded by ``orjson``
(``bench/bench_recorder.py`` prints it against the standard library's encoder: 4.3x on a
16-aircraft run's mix of records; at 64 aircraft a run's log is 250 MB of JSON). It writes
the same values: a number may be spelled differently (``1e-6`` for ``1e-06``), which every
JSON reader reads as the same float. What it would do differently falls back to the
standard library's encoder, so nothing else changes: a message whose JSON holds ``null`` is
checked for non-finite numbers (``orjson`` writes them as ``null`` without a word), and a
value ``orjson`` refuses (an integer beyond 64 bits) is encoded as before.

Derived channels. A :class:`WriterPlugin` sees the records of the topics it names as they are
logged and writes channels of its own through :class:`DerivedChannels` (after the record that
caused them). The Foxglove views (``ridsafe.tools.runlog.foxglove_channels``) are one; an
error in a plug-in costs its view of that record (one warning per topic), never the record.
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import os
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np
import orjson
from mcap.writer import CompressionType, Writer

from ridsafe.common import topics
from ridsafe.common.errors import RidsafeError
from ridsafe.common.logsink import Record, plain_record

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_FLUSH_EVERY_S",
    "JSONSCHEMA_ENCODING",
    "JSON_ENCODING",
    "DerivedChannels",
    "McapRecorder",
    "RecordEncoder",
    "RecorderError",
    "WriterPlugin",
    "derived_bytes",
    "run_plugins",
    "schema_bytes",
    "topic_schema",
]

logger = logging.getLogger(__name__)

DEFAULT_CHUNK_SIZE = 256 * 1024
DEFAULT_FLUSH_EVERY_S = 5.0
METADATA_NAME = "ridsafe.recorder"
JSON_ENCODING = "json"
JSONSCHEMA_ENCODING = "jsonschema"
LIBRARY = "ridsafe.tools.runlog (mcap-python)"


class RecorderError(RidsafeError):
    """The recorder cannot write what it was given (or was used after ``close()``)."""


class DerivedChannels(Protocol):
    """What a plug-in writes through: one message on a derived channel."""

    def write_derived(
        self, topic: str, schema_name: str, schema: Mapping[str, Any], t_s: float, message: Any
    ) -> None:
        """``message`` (a JSON-able dict, or JSON text already encoded) on ``topic`` at sim
        time ``t_s``; the channel is registered with ``schema`` on its first message."""
        ...


class WriterPlugin(Protocol):
    """Derives channels from the records of ``topics`` as the recorder writes them."""

    @property
    def topics(self) -> Collection[str]: ...

    def on_record(self, topic: str, t_s: float, record: Record, out: DerivedChannels) -> None:
        """Called after ``record`` is written; may write derived messages to ``out``."""
        ...


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
# orjson as the standard library's encoder above: keys that are not strings written as
# strings; dataclasses and datetimes handed to ``_to_plain`` (which refuses them, as the
# standard library does) instead of written as objects; numpy through ``_to_plain`` too (its
# own numpy support writes a float32 by its float32 digits, not by the float64 it widens to).
_ORJSON_OPTIONS = (
    orjson.OPT_NON_STR_KEYS | orjson.OPT_PASSTHROUGH_DATACLASS | orjson.OPT_PASSTHROUGH_DATETIME
)


def _has_nonfinite(value: Any) -> bool:
    """Might ``value`` hold a NaN or an infinity (what ``_sanitise`` nulls)? Never False when
    it does; True also for a list of numbers whose sum overflows (the caller then asks the
    standard library's encoder, which decides exactly)."""
    if isinstance(value, float | np.floating):
        return not math.isfinite(value)
    if isinstance(value, Mapping):
        return any(map(_has_nonfinite, value.values()))
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "fc" and not bool(np.isfinite(value).all())
    if isinstance(value, list | tuple):
        return _list_has_nonfinite(value)
    return False


def _list_has_nonfinite(values: list[Any] | tuple[Any, ...]) -> bool:
    """``_has_nonfinite`` of a list: numbers, or rows of numbers, summed in one C call (a NaN
    or an infinity makes the sum one); anything else element by element."""
    try:
        return not math.isfinite(sum(values))
    except TypeError:  # lists, mappings, strings, None among them
        pass
    if all(type(v) is list for v in values):  # rows (positions); not mappings: their keys
        try:
            return not math.isfinite(sum(itertools.chain.from_iterable(values)))
        except TypeError:
            pass
    return any(map(_has_nonfinite, values))


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
# What every sink of run records shares (the MCAP recorder, the live Foxglove server)


def topic_schema(topic: str, record: Record) -> Mapping[str, Any]:
    """The JSON schema of ``topic``'s channel (``topics.schema``), warning when its first
    ``record`` lacks required fields; a permissive one (and a warning) for an unknown topic."""
    if topic in topics.TOPICS:
        schema = topics.schema(topic)
        missing = [name for name in schema["required"] if name not in record]
        if missing:
            logger.warning("%s: first record lacks required fields %s", topic, missing)
        return schema
    logger.warning("%s: not in ridsafe.common.topics.TOPICS; permissive schema", topic)
    return {"title": topic, "type": "object"}


def schema_bytes(schema: Mapping[str, Any]) -> bytes:
    """A JSON schema as a channel's schema data."""
    return json.dumps(schema, separators=(",", ":")).encode()


def _fast_json(value: Any) -> bytes | None:
    """``value`` as JSON by ``orjson``, or None where the standard library's encoder must
    decide (module docstring, "Encoding speed"): a non-finite number possible, or a value
    ``orjson`` refuses."""
    try:
        data = orjson.dumps(value, default=_to_plain, option=_ORJSON_OPTIONS)
    except TypeError:  # orjson.JSONEncodeError
        return None
    if b"null" in data and _has_nonfinite(value):
        return None
    return data


def derived_bytes(message: Any) -> bytes:
    """A plug-in's message (a dict, or JSON text already encoded) as message data; a
    non-finite number in it is a ValueError (the plug-in's error, not the record's)."""
    if isinstance(message, str):
        return message.encode()
    fast = _fast_json(message)
    return fast if fast is not None else _ENCODER.encode(message).encode()


class RecordEncoder:
    """A record as its message data: compact JSON with ``t_s`` first (unless the record has
    one), non-finite numbers written as null and counted in ``nonfinite`` per
    ``"topic:field path"`` (one warning each)."""

    def __init__(self) -> None:
        self.nonfinite: dict[str, int] = {}

    def encode(self, topic: str, t_s: float, record: Record) -> bytes:
        body = self._body(topic, record)
        if "t_s" in record:
            return body
        head = b'{"t_s":' + repr(float(t_s)).encode()
        return head + b"}" if body == b"{}" else head + b"," + body[1:]

    def _body(self, topic: str, record: Record) -> bytes:
        """The record as JSON (module docstring, "Encoding speed")."""
        fast = _fast_json(record)
        return fast if fast is not None else self._standard_body(topic, record)

    def _standard_body(self, topic: str, record: Record) -> bytes:
        try:
            return _ENCODER.encode(record).encode()
        except ValueError:  # non-finite float (allow_nan=False)
            return _ENCODER.encode(self._nulled(topic, record)).encode()
        except TypeError as exc:
            where = _unserialisable_path(record)
            raise RecorderError(f"{topic}: field {where} cannot be written as JSON") from exc

    def _nulled(self, topic: str, record: Record) -> Any:
        found: list[str] = []
        clean = _sanitise(record, "", found)
        for path in found:
            key = f"{topic}:{path}"
            if key not in self.nonfinite:
                logger.warning("%s: non-finite number written as null (counted)", key)
                self.nonfinite[key] = 0
            self.nonfinite[key] += 1
        return clean


def run_plugins(
    plugins: Sequence[WriterPlugin],
    topic: str,
    t_s: float,
    record: Record,
    out: DerivedChannels,
    warned: set[str],
) -> None:
    """Each plug-in's view of ``record``; an error costs that view (one warning per topic in
    ``warned``), never the record."""
    for plugin in plugins:
        try:
            plugin.on_record(topic, t_s, record, out)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            if topic not in warned:
                warned.add(topic)
                logger.warning("%s: no derived view of this record (%r); skipped", topic, exc)


# --------------------------------------------------------------------------------------------
# Writing


class McapRecorder:
    """Writes one process's log records to an MCAP file (see the module docstring).

    ``chunk_size``: bytes of uncompressed records per chunk (what a crash can lose at most,
    together with ``flush_every_s``: the open chunk is closed whenever sim time has advanced
    that far since the last flush; None: only when full). ``plugins``: what derives channels
    from the records (e.g. ``foxglove_channels.FoxgloveChannels``), each called in this order.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_every_s: float | None = DEFAULT_FLUSH_EVERY_S,
        plugins: Sequence[WriterPlugin] = (),
    ) -> None:
        if chunk_size <= 0:
            raise ValueError(f"chunk_size must be > 0, got {chunk_size}")
        if flush_every_s is not None and not flush_every_s > 0.0:
            raise ValueError(f"flush_every_s must be > 0 or None, got {flush_every_s}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = _WriteThrough(self.path)
        self._writer = Writer(self._stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library=LIBRARY)
        self._closed = False
        self._channel_ids: dict[str, int] = {}
        self._schema_ids: dict[str, int] = {}
        self._warned: set[str] = set()
        self._encoder = RecordEncoder()
        self.message_count = 0
        self._flush_every_s = flush_every_s
        self._next_flush_s = flush_every_s if flush_every_s is not None else math.inf
        self._plugins_by_topic: dict[str, list[WriterPlugin]] = {}
        for plugin in plugins:
            for topic in plugin.topics:
                self._plugins_by_topic.setdefault(topic, []).append(plugin)

    # -- LogSink ------------------------------------------------------------------------------

    def log(self, topic: str, t_s: float, record: Record) -> None:
        """Write ``record`` on ``topic`` at sim time ``t_s`` (s, finite, >= 0)."""
        if self._closed:
            raise RecorderError(f"{topic}: log() after close() of {self.path}")
        record = plain_record(record)
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._open_topic(topic, record)
        log_time = _log_time_ns(topic, t_s)
        data = self._encoder.encode(topic, t_s, record)
        self._writer.add_message(channel_id, log_time, data, log_time)
        self.message_count += 1
        plugins = self._plugins_by_topic.get(topic)
        if plugins is not None:
            self._run_plugins(topic, plugins, t_s, record)
        if t_s >= self._next_flush_s:
            self.flush()
            assert self._flush_every_s is not None
            self._next_flush_s = t_s + self._flush_every_s

    @property
    def nonfinite_counts(self) -> Mapping[str, int]:
        """``"topic:field path"`` -> how many non-finite numbers were written as null."""
        return dict(self._encoder.nonfinite)

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
            counts = json.dumps(self._encoder.nonfinite, sort_keys=True)
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
        return self._register(topic, topic, topic_schema(topic, record))

    def _register(self, topic: str, schema_name: str, schema: Mapping[str, Any]) -> int:
        schema_id = self._schema_ids.get(schema_name)
        if schema_id is None:
            data = schema_bytes(schema)
            schema_id = self._writer.register_schema(schema_name, JSONSCHEMA_ENCODING, data)
            self._schema_ids[schema_name] = schema_id
        channel_id: int = self._writer.register_channel(topic, JSON_ENCODING, schema_id)
        self._channel_ids[topic] = channel_id
        return channel_id

    # -- derived channels (plug-ins) -------------------------------------------------------

    def _run_plugins(
        self, topic: str, plugins: list[WriterPlugin], t_s: float, record: Record
    ) -> None:
        run_plugins(plugins, topic, t_s, record, self, self._warned)

    def write_derived(
        self, topic: str, schema_name: str, schema: Mapping[str, Any], t_s: float, message: Any
    ) -> None:
        """A plug-in's message (a dict, or JSON text already encoded): see ``DerivedChannels``."""
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._register(topic, schema_name, schema)
        log_time = _log_time_ns(topic, t_s)
        self._writer.add_message(channel_id, log_time, derived_bytes(message), log_time)
        self.message_count += 1


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
