"""Serving a run's channels live to the Foxglove app (``ridsafe run --foxglove [HOST:]PORT``).

:class:`FoxgloveLiveServer` is a ``LogSink`` that publishes every record, as it is logged, on
a Foxglove WebSocket server (the ``foxglove-sdk`` package: ``pip install 'ridsafe[live]'``;
protocol ``foxglove.websocket.v1``). What a client sees is what the MCAP holds: one channel
per topic with the same JSON schema (``topics.schema``) and the same message bytes
(``writer.RecordEncoder``), and the derived Foxglove channels of
``foxglove_channels.FoxgloveChannels`` (3D scene, map fixes) with their schemas from
``foxglove_schemas``. Log times are sim time in nanoseconds, as in the MCAP.

``logsink.TeeSink`` puts it beside the run's own log writer. The server has its own
``foxglove.Context``, so two servers in one process (tests) never share channels.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ridsafe.common.errors import RidsafeError
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import Record, plain_record
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels
from ridsafe.tools.runlog.writer import (
    JSON_ENCODING,
    JSONSCHEMA_ENCODING,
    RecordEncoder,
    WriterPlugin,
    derived_bytes,
    run_plugins,
    schema_bytes,
    topic_schema,
)

if TYPE_CHECKING:
    import foxglove
    from foxglove.websocket import WebSocketServer

__all__ = ["DEFAULT_PORT", "FoxgloveLiveServer", "LiveViewError", "parse_host_port"]

logger = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765  # the Foxglove app's default for a WebSocket connection
SERVER_NAME = "ridsafe"


class LiveViewError(RidsafeError):
    """The live view cannot start (``foxglove-sdk`` missing, a bad address, a port in use)."""


def parse_host_port(text: str) -> tuple[str, int]:
    """``"[HOST:]PORT"`` -> (host, port); the host defaults to 127.0.0.1 (this machine only).
    Port 0 asks the system for a free one."""
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host = DEFAULT_HOST
    try:
        port = int(port_text)
    except ValueError:
        raise LiveViewError(f"--foxglove {text!r}: expected [HOST:]PORT") from None
    if not 0 <= port <= 65535:
        raise LiveViewError(f"--foxglove {text!r}: port must be 0-65535")
    return host or DEFAULT_HOST, port


def _sdk() -> Any:
    try:
        import foxglove  # noqa: PLC0415 (an optional extra)
    except ImportError:
        raise LiveViewError(
            "the live Foxglove view needs the foxglove-sdk package: pip install 'ridsafe[live]'"
        ) from None
    return foxglove


class FoxgloveLiveServer:
    """A ``LogSink`` serving every record (and the derived Foxglove channels) live.

    ``origin``: the scenario origin for the map fixes (else taken from ``/run/meta``).
    ``port`` 0 binds a free port; :attr:`port` says which."""

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        origin: GeodeticOrigin | None = None,
        plugins: tuple[WriterPlugin, ...] | None = None,
    ) -> None:
        sdk = _sdk()
        self._sdk = sdk
        self._context: foxglove.Context = sdk.Context()
        try:
            self._server: WebSocketServer = sdk.start_server(
                name=SERVER_NAME, host=host, port=port, context=self._context
            )
        except RuntimeError as exc:
            raise LiveViewError(f"cannot serve Foxglove on {host}:{port}: {exc}") from exc
        self.host = host
        self._channels: dict[str, foxglove.Channel] = {}
        self._encoder = RecordEncoder()
        self._warned: set[str] = set()
        self._plugins_by_topic: dict[str, list[WriterPlugin]] = {}
        for plugin in (FoxgloveChannels(origin),) if plugins is None else plugins:
            for topic in plugin.topics:
                self._plugins_by_topic.setdefault(topic, []).append(plugin)
        self._closed = False

    @property
    def port(self) -> int:
        return int(self._server.port)

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def log(self, topic: str, t_s: float, record: Record) -> None:
        if self._closed:
            return
        record = plain_record(record)
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._open(topic, topic, topic_schema(topic, record))
        channel.log(self._encoder.encode(topic, t_s, record), log_time=_log_time_ns(t_s))
        plugins = self._plugins_by_topic.get(topic)
        if plugins is not None:
            run_plugins(plugins, topic, t_s, record, self, self._warned)

    def write_derived(
        self, topic: str, schema_name: str, schema: Mapping[str, Any], t_s: float, message: Any
    ) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._open(topic, schema_name, schema)
        channel.log(derived_bytes(message), log_time=_log_time_ns(t_s))

    def _open(self, topic: str, schema_name: str, schema: Mapping[str, Any]) -> foxglove.Channel:
        described = self._sdk.Schema(
            name=schema_name, encoding=JSONSCHEMA_ENCODING, data=schema_bytes(schema)
        )
        channel: foxglove.Channel = self._sdk.Channel(
            topic, schema=described, message_encoding=JSON_ENCODING, context=self._context
        )
        self._channels[topic] = channel
        return channel

    def close(self) -> None:
        """Stop serving (clients are disconnected). Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        for channel in self._channels.values():
            channel.close()
        self._server.stop()

    def __enter__(self) -> FoxgloveLiveServer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def _log_time_ns(t_s: float) -> int:
    return round(max(t_s, 0.0) * 1e9)
