"""The live Foxglove view, watched by a real WebSocket client speaking the Foxglove WebSocket
protocol v1: channels are advertised with the MCAP's schemas, and subscribed messages arrive
as the MCAP's bytes and satisfy those schemas.

The client offers both names of that protocol, as the Foxglove app does: the spec's
``foxglove.websocket.v1`` and ``foxglove.sdk.v1``, the one foxglove-sdk's server (0.30)
accepts (a client offering only the first gets HTTP 400)."""

from __future__ import annotations

import asyncio
import json
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

import pytest

from ridsafe.common import topics
from ridsafe.tools.runlog.foxglove_channels import AIRCRAFT_TOPIC
from ridsafe.tools.runlog.foxglove_live import FoxgloveLiveServer, LiveViewError, parse_host_port
from ridsafe.tools.runlog.foxglove_schemas import SCENE_UPDATE, SCHEMAS
from ridsafe.tools.runlog.writer import RecordEncoder
from tests.tools.runlog.mcap_files import check_schema, meta_record, truth_record

pytest.importorskip("foxglove")
websockets = pytest.importorskip("websockets")

ROOT = Path(__file__).resolve().parents[3]
SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")
MESSAGE_DATA = 0x01  # binary opcode: subscription id u32, log time u64 (ns), payload
pytestmark = pytest.mark.udp


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class Client:
    """A Foxglove WebSocket client: advertised channels by topic, messages by topic."""

    def __init__(self, connection: Any) -> None:
        self.connection = connection
        self.channels: dict[str, dict[str, Any]] = {}
        self.subscribed: dict[int, str] = {}  # subscription id -> topic
        self.messages: dict[str, list[tuple[int, bytes]]] = {}
        self.server_info: dict[str, Any] | None = None

    async def pump(self, until: Callable[[], bool], timeout_s: float) -> bool:
        """Take frames until ``until()``; False if the server closed the connection first."""
        deadline = time.monotonic() + timeout_s
        while not until():
            left = deadline - time.monotonic()
            assert left > 0, f"timed out; channels {sorted(self.channels)}"
            try:
                frame = await asyncio.wait_for(self.connection.recv(), min(left, 1.0))
            except TimeoutError:
                continue
            except websockets.ConnectionClosed:
                return False
            self._take(frame)
        return True

    def _take(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            op = json.loads(frame)
            if op["op"] == "serverInfo":
                self.server_info = op
            elif op["op"] == "advertise":
                for channel in op["channels"]:
                    self.channels[channel["topic"]] = channel
            return
        assert frame[0] == MESSAGE_DATA, frame[:1]
        subscription, log_time_ns = struct.unpack_from("<IQ", frame, 1)
        self.messages.setdefault(self.subscribed[subscription], []).append(
            (log_time_ns, bytes(frame[13:]))
        )

    async def subscribe(self, wanted: Collection[str]) -> None:
        subscriptions = []
        for topic in wanted:
            sub_id = len(self.subscribed) + 1
            self.subscribed[sub_id] = topic
            subscriptions.append({"id": sub_id, "channelId": self.channels[topic]["id"]})
        await self.connection.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))


async def connect(port: int, timeout_s: float) -> Client:
    """Connect (retrying while the server is not up yet) and read its serverInfo."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            connection = await websockets.connect(
                f"ws://127.0.0.1:{port}",
                subprotocols=list(SUBPROTOCOLS),
                max_size=None,
                close_timeout=1.0,  # a server busy with its run may never answer the close
            )
            break
        except OSError:
            assert time.monotonic() < deadline, f"no Foxglove server on port {port}"
            await asyncio.sleep(0.2)
    assert connection.subprotocol in SUBPROTOCOLS
    client = Client(connection)
    assert await client.pump(lambda: client.server_info is not None, 10.0)
    return client


def decoded_and_checked(client: Client, topic: str) -> list[dict[str, Any]]:
    """Every message received on ``topic``, decoded and checked against the advertised schema."""
    channel = client.channels[topic]
    assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
    schema = json.loads(channel["schema"])
    decoded = []
    for _log_time_ns, payload in client.messages[topic]:
        message = json.loads(payload)
        check_schema(message, schema, topic)
        decoded.append(message)
    return decoded


def test_records_and_derived_channels_reach_a_websocket_client_as_in_the_mcap() -> None:
    async def watch() -> None:
        with FoxgloveLiveServer("127.0.0.1", free_port()) as server:
            server.log(topics.RUN_META, 0.0, meta_record())
            server.log(topics.TRUTH, 0.0, truth_record(0.0))  # both channels now exist
            client = await connect(server.port, 10.0)
            wanted = (topics.TRUTH, AIRCRAFT_TOPIC)
            await client.pump(lambda: all(t in client.channels for t in wanted), 10.0)
            await client.subscribe(wanted)
            await asyncio.sleep(0.5)  # the server takes the subscription
            sent = [(0.1 * k, truth_record(0.1 * k)) for k in range(1, 11)]
            for t_s, record in sent:
                server.log(topics.TRUTH, t_s, record)
            await client.pump(
                lambda: all(len(client.messages.get(t, ())) >= len(sent) for t in wanted), 10.0
            )
            await client.connection.close()
        # the same schemas as the MCAP: the topic's own, and the Foxglove one
        assert json.loads(client.channels[topics.TRUTH]["schema"]) == topics.schema(topics.TRUTH)
        aircraft = client.channels[AIRCRAFT_TOPIC]
        assert aircraft["schemaName"] == SCENE_UPDATE
        assert json.loads(aircraft["schema"]) == SCHEMAS[SCENE_UPDATE]
        # the same bytes as the MCAP, at sim time
        encoder = RecordEncoder()
        expected = [(round(t * 1e9), encoder.encode(topics.TRUTH, t, r)) for t, r in sent]
        assert client.messages[topics.TRUTH][-len(sent) :] == expected
        assert len(decoded_and_checked(client, topics.TRUTH)) >= len(sent)
        scenes = decoded_and_checked(client, AIRCRAFT_TOPIC)
        assert all(scene["entities"] for scene in scenes)

    asyncio.run(watch())


def test_host_and_port_are_parsed_and_checked() -> None:
    assert parse_host_port("8765") == ("127.0.0.1", 8765)
    assert parse_host_port("0.0.0.0:9000") == ("0.0.0.0", 9000)
    for bad in ("x", "host:", "70000"):
        with pytest.raises(LiveViewError):
            parse_host_port(bad)


def test_a_port_in_use_is_a_clear_error() -> None:
    with (
        FoxgloveLiveServer("127.0.0.1", free_port()) as first,
        pytest.raises(LiveViewError, match="cannot serve"),
    ):
        FoxgloveLiveServer("127.0.0.1", first.port)


@pytest.mark.slow
def test_ridsafe_run_serves_its_channels_live(tmp_path: Path) -> None:
    port = free_port()
    console = tmp_path / "console.txt"  # a file: an unread pipe would fill and stall the run
    run = subprocess.Popen(
        [sys.executable, "-m", "ridsafe.tools.cli", "run", "--mode", "lockstep",
         "--foxglove", f"127.0.0.1:{port}", "--aircraft", "4", "--duration", "120",
         "--out", str(tmp_path / "out")],
        cwd=ROOT, stdout=console.open("w"), stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip

    async def watch() -> Client:
        client = await connect(port, 120.0)
        assert await client.pump(lambda: AIRCRAFT_TOPIC in client.channels, 120.0)
        await client.subscribe([AIRCRAFT_TOPIC])
        # lockstep runs many times faster than real time: the run may end (and the server
        # close) soon after the subscription; some of its messages must have arrived by then
        await client.pump(lambda: len(client.messages.get(AIRCRAFT_TOPIC, ())) >= 5, 60.0)
        await client.connection.close()
        return client

    try:
        client = asyncio.run(watch())
        run.wait(timeout=300)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    out = console.read_text()
    assert run.returncode == 0, out
    assert f"Foxglove: open ws://127.0.0.1:{port}" in out
    assert decoded_and_checked(client, AIRCRAFT_TOPIC)
    assert (tmp_path / "out" / "run.mcap").stat().st_size > 0
