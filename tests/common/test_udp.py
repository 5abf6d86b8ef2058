"""Tests for ridsafe.common.udp over real sockets on 127.0.0.1."""

from __future__ import annotations

import errno
import logging
import select
import socket
import sys
import time
from collections.abc import Iterator

import pytest

from ridsafe.common.errors import ConnectionStringError, UdpError
from ridsafe.common.udp import (
    ConnectionSpec,
    UdpEndpoint,
    UdpMode,
    parse_connection_string,
)

pytestmark = pytest.mark.udp


def receive(
    endpoint: UdpEndpoint, count: int, timeout_s: float = 2.0
) -> list[tuple[bytes, tuple[str, int]]]:
    """Wait (select on fileno) until ``count`` datagrams arrived; return them."""
    got: list[tuple[bytes, tuple[str, int]]] = []
    deadline = time.monotonic() + timeout_s
    while len(got) < count:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            break
        select.select([endpoint], [], [], remaining)
        got.extend(endpoint.recv_all())
    return got


@pytest.fixture
def listener() -> Iterator[UdpEndpoint]:
    with UdpEndpoint() as endpoint:
        yield endpoint


def test_binds_loopback_on_an_ephemeral_port_by_default(listener: UdpEndpoint) -> None:
    host, port = listener.local_address
    assert host == "127.0.0.1"
    assert port > 0
    assert listener.peer is None and listener.remote is None and listener.destination is None


def test_two_endpoints_exchange_datagrams(listener: UdpEndpoint) -> None:
    with UdpEndpoint(remote=listener.local_address) as sender:
        assert sender.send(b"ping")
        assert receive(listener, 1) == [(b"ping", sender.local_address)]
        assert listener.peer == sender.local_address
        assert listener.send(b"pong")  # no address: replies to the last peer
        assert receive(sender, 1) == [(b"pong", listener.local_address)]
        assert sender.stats.datagrams_sent == 1 and sender.stats.bytes_sent == 4
        assert listener.stats.datagrams_received == 1 and listener.stats.bytes_received == 4


def test_reply_goes_to_the_most_recent_peer(listener: UdpEndpoint) -> None:
    with UdpEndpoint() as first, UdpEndpoint() as second:
        first.send(b"1", listener.local_address)
        receive(listener, 1)
        second.send(b"2", listener.local_address)
        receive(listener, 1)
        assert listener.peer == second.local_address
        listener.send(b"reply")
        assert receive(second, 1) == [(b"reply", listener.local_address)]
        assert first.recv_all() == []


def test_udpout_keeps_its_fixed_remote(listener: UdpEndpoint) -> None:
    with UdpEndpoint(remote=listener.local_address) as out, UdpEndpoint() as stranger:
        stranger.send(b"hello", out.local_address)
        receive(out, 1)
        assert out.peer == stranger.local_address
        out.send(b"to remote")
        assert receive(listener, 1) == [(b"to remote", out.local_address)]
        assert stranger.recv_all() == []


def test_explicit_address_overrides_the_destination(listener: UdpEndpoint) -> None:
    with UdpEndpoint(remote=("127.0.0.1", 9)) as out:
        out.send(b"x", listener.local_address)
        assert receive(listener, 1) == [(b"x", out.local_address)]


def test_sending_with_no_known_peer_raises(listener: UdpEndpoint) -> None:
    with pytest.raises(UdpError, match="no destination"):
        listener.send(b"nobody to talk to")
    assert listener.stats.datagrams_sent == 0


def test_non_blocking_drain_of_many_datagrams(listener: UdpEndpoint) -> None:
    started = time.perf_counter()
    assert listener.recv_all() == []  # nothing waiting: returns at once
    assert time.perf_counter() - started < 0.05
    # Batches of 100: the kernel's default receive buffer holds a few hundred small datagrams.
    batches, batch = 5, 100
    received: list[tuple[bytes, tuple[str, int]]] = []
    with UdpEndpoint(remote=listener.local_address) as sender:
        for b in range(batches):
            for i in range(b * batch, (b + 1) * batch):
                assert sender.send(i.to_bytes(4, "big"))
            first_three = listener.recv_all(max_datagrams=3)
            assert len(first_three) == 3  # max_datagrams is honoured
            received += first_three + receive(listener, batch - 3)
    payloads = [int.from_bytes(data, "big") for data, _ in received]
    assert payloads == list(range(batches * batch))  # all of them, in order, none twice
    assert listener.recv_all() == []
    assert listener.stats.datagrams_received == batches * batch


def test_receive_buffer_can_be_enlarged() -> None:
    with (
        UdpEndpoint() as default,
        UdpEndpoint(recv_buffer_bytes=default.recv_buffer_bytes * 2) as big,
    ):
        assert big.recv_buffer_bytes >= default.recv_buffer_bytes


def test_send_to_a_closed_port_does_not_crash(listener: UdpEndpoint) -> None:
    with UdpEndpoint() as gone:
        dead_address = gone.local_address
    with UdpEndpoint(remote=dead_address) as sender:
        for _ in range(3):
            sender.send(b"into the void")
        time.sleep(0.01)
        assert sender.recv_all() == []
        sender.send(b"still alive", listener.local_address)
        assert receive(listener, 1)[0][0] == b"still alive"


class FlakySocket:
    """Wraps a real socket; raises the queued errors first."""

    def __init__(self, inner: socket.socket, errors: list[OSError]) -> None:
        self.inner = inner
        self.errors = errors

    def sendto(self, data: bytes, address: tuple[str, int]) -> int:
        if self.errors:
            raise self.errors.pop(0)
        return self.inner.sendto(data, address)

    def recvmsg(
        self, size: int, ancillary_size: int
    ) -> tuple[bytes, list[tuple[int, int, bytes]], int, tuple[str, int]]:
        if self.errors:
            raise self.errors.pop(0)
        data, ancillary, flags, address = self.inner.recvmsg(size, ancillary_size)
        return data, ancillary, flags, address

    def getsockname(self) -> tuple[str, int]:
        name: tuple[str, int] = self.inner.getsockname()
        return name


def test_transient_errors_are_logged_and_counted(
    listener: UdpEndpoint, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    real = listener._sock
    errors: list[OSError] = [ConnectionRefusedError(errno.ECONNREFUSED, "refused")] * 2
    monkeypatch.setattr(listener, "_sock", FlakySocket(real, errors))
    with caplog.at_level(logging.DEBUG, logger="ridsafe.common.udp"):
        assert listener.send(b"x", ("127.0.0.1", 9)) is False
        assert listener.send(b"x", ("127.0.0.1", 9)) is False
    assert listener.stats.send_errors == 2 and listener.stats.datagrams_sent == 0
    levels = [r.levelno for r in caplog.records]
    assert levels == [logging.WARNING, logging.DEBUG]  # first of a kind loud, then quiet

    errors.extend([ConnectionResetError(errno.ECONNRESET, "reset")])
    with UdpEndpoint(remote=listener.local_address) as sender:
        sender.send(b"after the error")
        select.select([real], [], [], 2.0)
        got = listener.recv_all()
    assert [data for data, _ in got] == [b"after the error"]
    assert listener.stats.recv_errors == 1


def test_other_os_errors_propagate(listener: UdpEndpoint, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(
        listener, "_sock", FlakySocket(listener._sock, [OSError(errno.EMSGSIZE, "too long")])
    )
    with pytest.raises(OSError, match="too long"):
        listener.send(b"x", ("127.0.0.1", 9))


def test_close_is_idempotent_and_final() -> None:
    endpoint = UdpEndpoint()
    assert endpoint.fileno() >= 0
    endpoint.close()
    endpoint.close()
    assert endpoint.closed
    with pytest.raises(UdpError, match="closed"):
        endpoint.send(b"x", ("127.0.0.1", 9))
    with pytest.raises(UdpError, match="closed"):
        endpoint.recv_all()
    with UdpEndpoint() as scoped:
        pass
    assert scoped.closed


def test_all_interfaces_only_when_asked() -> None:
    with pytest.raises(UdpError, match="empty bind_host"):
        UdpEndpoint(bind_host="")
    with UdpEndpoint(bind_host="0.0.0.0") as everywhere:
        assert everywhere.local_address[0] == "0.0.0.0"


def test_bind_failure_is_a_udp_error(listener: UdpEndpoint) -> None:
    with pytest.raises(UdpError, match="cannot bind"):
        UdpEndpoint(bind_port=listener.local_address[1])


def test_endpoints_from_connection_strings() -> None:
    with UdpEndpoint.from_spec("udpin:127.0.0.1:0") as server:
        port = server.local_address[1]
        with UdpEndpoint.from_spec(f"udpout:localhost:{port}") as client:
            assert client.remote == ("127.0.0.1", port)
            assert client.local_address[0] == "127.0.0.1"
            client.send(b"hb")
            assert receive(server, 1) == [(b"hb", client.local_address)]
            server.send(b"ack")
            assert receive(client, 1) == [(b"ack", server.local_address)]


# --------------------------------------------------------------------------------------------
# Connection strings


@pytest.mark.parametrize(
    ("text", "spec"),
    [
        ("udpin:127.0.0.1:14550", ConnectionSpec(UdpMode.UDPIN, "127.0.0.1", 14550)),
        ("udpout:localhost:14560", ConnectionSpec(UdpMode.UDPOUT, "localhost", 14560)),
        ("udp:0.0.0.0:14550", ConnectionSpec(UdpMode.UDP, "0.0.0.0", 14550)),
        ("  UDPIN:127.0.0.1:0 ", ConnectionSpec(UdpMode.UDPIN, "127.0.0.1", 0)),
        (
            "udpout:sitl-host.example:65535",
            ConnectionSpec(UdpMode.UDPOUT, "sitl-host.example", 65535),
        ),
    ],
)
def test_parse_connection_string(text: str, spec: ConnectionSpec) -> None:
    parsed = parse_connection_string(text)
    assert parsed == spec
    assert parse_connection_string(str(parsed)) == parsed
    assert parsed.mode.listens is (parsed.mode is not UdpMode.UDPOUT)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "expected MODE:HOST:PORT"),
        ("udpin", "expected MODE:HOST:PORT"),
        ("udpin:127.0.0.1", "expected MODE:HOST:PORT"),
        ("udpin:127.0.0.1:14550:1", "expected MODE:HOST:PORT"),
        ("udpin:[::1]:14550", "expected MODE:HOST:PORT"),
        ("tcp:127.0.0.1:5760", "unknown mode 'tcp'"),
        ("udpbcast:127.0.0.1:14550", "unknown mode 'udpbcast'"),
        ("udpin::14550", "empty host"),
        ("udpin:bad host:14550", "expected an IPv4 address or host name"),
        ("udpin:127.0.0.1:port", "expected a port 0-65535, got 'port'"),
        ("udpin:127.0.0.1:-1", "expected a port 0-65535"),
        ("udpin:127.0.0.1:70000", "expected a port 0-65535, got '70000'"),
        ("udpout:127.0.0.1:0", "expected a port 1-65535, got '0'"),
    ],
)
def test_malformed_connection_strings(text: str, reason: str) -> None:
    with pytest.raises(ConnectionStringError) as info:
        parse_connection_string(text)
    assert reason in str(info.value)
    assert repr(text) in str(info.value)
    assert isinstance(info.value, ValueError)


def _flood(endpoint: UdpEndpoint, count: int) -> None:
    with UdpEndpoint(remote=endpoint.local_address) as sender:
        for i in range(count):
            sender.send(i.to_bytes(4, "big") * 64)


@pytest.mark.skipif(sys.platform != "linux", reason="SO_RXQ_OVFL is Linux's")
def test_datagrams_lost_in_a_full_receive_buffer_are_counted() -> None:
    """Oracle: on loopback a datagram is lost only in the receiver's full buffer, so what was
    read plus what the kernel says it dropped is what was sent. The count comes with the
    next datagram received after the drops."""
    with UdpEndpoint(recv_buffer_bytes=4096) as listener:
        _flood(listener, 500)  # nobody reads: the small buffer fills, the rest is dropped
        received = len(receive(listener, 500, timeout_s=0.5))
        assert listener.stats.kernel_drops == 0  # nothing received after the drops yet
        _flood(listener, 1)
        received += len(receive(listener, 1))
        assert received < 500
        assert listener.stats.kernel_drops == 501 - received
