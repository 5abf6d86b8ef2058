"""A non-blocking UDP endpoint for the runners, and pymavlink-style connection strings.

Cores never touch sockets: a runner owns :class:`UdpEndpoint` objects, drains them with
:meth:`UdpEndpoint.recv_all`, hands the bytes to a core, and sends what the core returns.

Addressing follows pymavlink's ``mavudp``:

- ``udpin:HOST:PORT`` binds HOST:PORT and replies to whoever spoke last (it cannot send until a
  peer has spoken). ``udp:HOST:PORT`` is pymavlink's legacy spelling of the same. The
  runner (``common.runner``) replaces "whoever spoke last" by a peer earned with a genuine
  frame and locked (``common.peer_lock``) when its core can vet senders.
- ``udpout:HOST:PORT`` binds an ephemeral local port and always sends to HOST:PORT.

Everything binds 127.0.0.1 by default. Listening on all interfaces needs an explicit
``0.0.0.0``; an empty host (pymavlink's ``udp::14550``) is refused rather than read as "all".
IPv4 only.

Network errors that a live link should survive (ICMP port unreachable surfacing as
ECONNREFUSED/ECONNRESET, a full send buffer, an unreachable network) are logged (first of each
kind at WARNING, later ones at DEBUG) and counted in :attr:`UdpEndpoint.stats`; ``send`` then
returns False. Other OSErrors (e.g. a datagram too large) are bugs and propagate.

Datagrams that arrive while the kernel's receive buffer is full (a flood, or a process that
fell behind) are lost before any application code sees them. On Linux the endpoint asks the
kernel to say how many (``SO_RXQ_OVFL``: the socket's running drop count comes with each
datagram received) and keeps it in :attr:`UdpStats.kernel_drops`, so a runner can count them
with the core's other drops; drops after the last datagram received are told with the next
one. Elsewhere the count stays 0.
"""

from __future__ import annotations

import enum
import errno
import logging
import re
import socket
import struct
from dataclasses import dataclass
from types import TracebackType

from ridsafe.common.errors import ConnectionStringError, UdpError

__all__ = [
    "Address",
    "ConnectionSpec",
    "UdpEndpoint",
    "UdpMode",
    "UdpStats",
    "parse_connection_string",
]

logger = logging.getLogger(__name__)

#: An IPv4 (host, port) pair, as the socket module uses.
Address = tuple[str, int]

LOOPBACK_HOST = "127.0.0.1"
#: Listening on every interface: used only when asked for explicitly.
ALL_INTERFACES_HOST = "0.0.0.0"
_MAX_DATAGRAM_BYTES = 65535
_MAX_PORT = 65535
_HOST_RE = re.compile(r"^[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?$")
#: Linux's socket option for the receive queue's drop count (``<asm-generic/socket.h>``).
_SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40)
_DROP_COUNT = struct.Struct("=I")

# errno values a live link survives: count, log, carry on.
_TRANSIENT_ERRNOS = frozenset(
    {
        errno.ECONNREFUSED,
        errno.ECONNRESET,
        errno.EAGAIN,
        errno.EWOULDBLOCK,
        errno.ENOBUFS,
        errno.EHOSTUNREACH,
        errno.ENETUNREACH,
        errno.EINTR,
    }
)


class UdpMode(enum.Enum):
    """How a connection string asks to be connected."""

    UDPIN = "udpin"  # bind HOST:PORT, reply to the last peer
    UDPOUT = "udpout"  # send to HOST:PORT from an ephemeral port
    UDP = "udp"  # pymavlink's legacy alias of udpin

    @property
    def listens(self) -> bool:
        """True if HOST:PORT is the local address to bind (udpin, udp)."""
        return self is not UdpMode.UDPOUT


@dataclass(frozen=True)
class ConnectionSpec:
    """A parsed connection string such as ``udpin:127.0.0.1:14550``."""

    mode: UdpMode
    host: str
    port: int

    def __str__(self) -> str:
        return f"{self.mode.value}:{self.host}:{self.port}"


def parse_connection_string(text: str) -> ConnectionSpec:
    """Parse ``udpin:HOST:PORT``, ``udp:HOST:PORT`` or ``udpout:HOST:PORT``.

    HOST is an IPv4 address or a host name (not empty); PORT is 0-65535 for listening modes
    (0 = any free port) and 1-65535 for ``udpout``. Raises ConnectionStringError otherwise.
    """
    expected = "expected MODE:HOST:PORT with MODE one of udpin, udpout, udp"
    parts = text.strip().split(":")
    if len(parts) != 3:
        raise ConnectionStringError(f"connection string {text!r}: {expected}")
    mode_text, host, port_text = parts
    try:
        mode = UdpMode(mode_text.lower())
    except ValueError:
        raise ConnectionStringError(
            f"connection string {text!r}: unknown mode {mode_text!r}; {expected}"
        ) from None
    if not host:
        raise ConnectionStringError(
            f"connection string {text!r}: empty host; write {ALL_INTERFACES_HOST} to listen on "
            f"all interfaces or {LOOPBACK_HOST} for this machine only"
        )
    if not _HOST_RE.match(host):
        raise ConnectionStringError(
            f"connection string {text!r}: expected an IPv4 address or host name, got {host!r}"
        )
    low = 0 if mode.listens else 1
    if not port_text.isdigit() or not low <= int(port_text) <= _MAX_PORT:
        raise ConnectionStringError(
            f"connection string {text!r}: expected a port {low}-{_MAX_PORT}, got {port_text!r}"
        )
    return ConnectionSpec(mode, host, int(port_text))


@dataclass
class UdpStats:
    """Running counts of one endpoint's traffic and of the errors it survived."""

    datagrams_sent: int = 0
    bytes_sent: int = 0
    datagrams_received: int = 0
    bytes_received: int = 0
    send_errors: int = 0
    recv_errors: int = 0
    #: Datagrams the kernel dropped for a full receive buffer (Linux; module docstring).
    kernel_drops: int = 0


class UdpEndpoint:
    """A non-blocking IPv4 UDP socket that remembers who it heard from last.

    ``send(data)`` without an address goes to ``remote`` if one was given (udpout), else to the
    last peer heard (udpin); with neither it raises :class:`~ridsafe.common.errors.UdpError`.
    """

    def __init__(
        self,
        bind_host: str = LOOPBACK_HOST,
        bind_port: int = 0,
        remote: Address | None = None,
        *,
        recv_buffer_bytes: int | None = None,
    ) -> None:
        if not bind_host:
            raise UdpError(
                f"UdpEndpoint: empty bind_host; pass {ALL_INTERFACES_HOST!r} explicitly to "
                "listen on all interfaces"
            )
        if bind_host == ALL_INTERFACES_HOST:
            logger.info("UDP endpoint listening on all interfaces (port %d)", bind_port)
        self._remote = _resolve(remote) if remote is not None else None
        self._peer: Address | None = None
        #: ``recv_all`` takes every sender as the peer (pymavlink's rule); a runner that vets
        #: senders itself (``common.peer_lock``) turns this off and calls ``set_peer``.
        self.learns_peer = True
        self._errnos_logged: set[int] = set()
        self.stats = UdpStats()
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            if recv_buffer_bytes is not None:
                self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, recv_buffer_bytes)
            self._sock.bind((bind_host, bind_port))
            self._sock.setblocking(False)
        except OSError as err:
            self._sock.close()
            raise UdpError(f"UdpEndpoint: cannot bind {bind_host}:{bind_port}: {err}") from err
        self._ancillary_bytes = _ask_for_drop_counts(self._sock)
        self._closed = False
        logger.debug("UDP endpoint bound to %s:%d", *self.local_address)

    @classmethod
    def from_spec(cls, spec: ConnectionSpec | str, *, local_host: str | None = None) -> UdpEndpoint:
        """Open the endpoint a connection string (or its parsed form) describes.

        For ``udpout`` the local side binds ``local_host`` port 0; by default 127.0.0.1 when
        the remote is a loopback address, else all interfaces (a remote elsewhere cannot be
        reached from the loopback interface).
        """
        if isinstance(spec, str):
            spec = parse_connection_string(spec)
        if spec.mode.listens:
            return cls(spec.host, spec.port)
        remote = _resolve((spec.host, spec.port))
        if local_host is None:
            is_loopback = remote[0].startswith("127.")
            local_host = LOOPBACK_HOST if is_loopback else ALL_INTERFACES_HOST
        return cls(local_host, 0, remote)

    # ----------------------------------------------------------------------------------------
    # Addresses

    @property
    def local_address(self) -> Address:
        """The (host, port) this endpoint is bound to."""
        self._check_open("local_address")
        host, port = self._sock.getsockname()
        return str(host), int(port)

    @property
    def recv_buffer_bytes(self) -> int:
        """The kernel receive buffer size granted (Linux reports twice what was asked, capped by
        ``net.core.rmem_max``). Datagrams that arrive while it is full are lost."""
        self._check_open("recv_buffer_bytes")
        return int(self._sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))

    @property
    def remote(self) -> Address | None:
        """The fixed destination given at construction (udpout), or None."""
        return self._remote

    @property
    def peer(self) -> Address | None:
        """The sender of the most recent datagram received, or None before the first."""
        return self._peer

    def set_peer(self, address: Address) -> None:
        """Make ``address`` the peer that ``send`` without an address goes to."""
        self._peer = address

    @property
    def destination(self) -> Address | None:
        """Where ``send(data)`` without an address goes: ``remote``, else ``peer``."""
        return self._remote if self._remote is not None else self._peer

    # ----------------------------------------------------------------------------------------
    # I/O

    def send(self, data: bytes, addr: Address | None = None) -> bool:
        """Send one datagram to ``addr`` or :attr:`destination`.

        Returns True if handed to the OS, False if a transient network error dropped it (logged
        and counted). Raises UdpError when closed or when there is nowhere to send.
        """
        self._check_open("send")
        dest = addr if addr is not None else self.destination
        if dest is None:
            raise UdpError(
                "UdpEndpoint.send: no destination: pass addr, give a remote, or wait until a "
                "peer has spoken (udpin)"
            )
        try:
            self._sock.sendto(data, dest)
        except OSError as err:
            if not _is_transient(err):
                raise
            self.stats.send_errors += 1
            self._log_error("send to", dest, err)
            return False
        self.stats.datagrams_sent += 1
        self.stats.bytes_sent += len(data)
        return True

    def recv_all(self, max_datagrams: int = 1024) -> list[tuple[bytes, Address]]:
        """Drain up to ``max_datagrams`` waiting datagrams without blocking, oldest first.

        Returns ``[(data, sender), ...]``, empty if nothing is waiting. Remembers the last
        sender as :attr:`peer` unless :attr:`learns_peer` is off. Transient errors are
        counted and skipped.
        """
        self._check_open("recv_all")
        received: list[tuple[bytes, Address]] = []
        for _ in range(max_datagrams):
            try:
                data, ancillary, _flags, sender = self._sock.recvmsg(
                    _MAX_DATAGRAM_BYTES, self._ancillary_bytes
                )
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:
                if not _is_transient(err):
                    raise
                self.stats.recv_errors += 1
                self._log_error("receive on", self.local_address, err)
                continue
            for level, kind, value in ancillary:
                if level == socket.SOL_SOCKET and kind == _SO_RXQ_OVFL:
                    self.stats.kernel_drops = _DROP_COUNT.unpack_from(value)[0]
            address: Address = (str(sender[0]), int(sender[1]))
            received.append((data, address))
            if self.learns_peer:
                self._peer = address
        self.stats.datagrams_received += len(received)
        self.stats.bytes_received += sum(len(data) for data, _ in received)
        return received

    def fileno(self) -> int:
        """The socket's file descriptor, for ``select``/``selectors``."""
        self._check_open("fileno")
        return self._sock.fileno()

    # ----------------------------------------------------------------------------------------
    # Lifetime

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Close the socket. Closing twice is harmless."""
        if not self._closed:
            self._closed = True
            self._sock.close()

    def __enter__(self) -> UdpEndpoint:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        where = "closed" if self._closed else "{}:{}".format(*self.local_address)
        return f"UdpEndpoint({where}, remote={self._remote}, peer={self._peer})"

    def _check_open(self, what: str) -> None:
        if self._closed:
            raise UdpError(f"UdpEndpoint.{what}: the endpoint is closed")

    def _log_error(self, action: str, address: Address, err: OSError) -> None:
        code = err.errno if err.errno is not None else -1
        level = logging.DEBUG if code in self._errnos_logged else logging.WARNING
        self._errnos_logged.add(code)
        logger.log(level, "UDP %s %s:%d failed (counted, continuing): %s", action, *address, err)


def _ask_for_drop_counts(sock: socket.socket) -> int:
    """Turn on ``SO_RXQ_OVFL`` where the system has it; the ancillary buffer size ``recvmsg``
    then needs (0 where it does not)."""
    try:
        sock.setsockopt(socket.SOL_SOCKET, _SO_RXQ_OVFL, 1)
    except OSError:
        return 0
    return socket.CMSG_SPACE(_DROP_COUNT.size)


def _is_transient(err: OSError) -> bool:
    return isinstance(err, BlockingIOError | ConnectionError) or err.errno in _TRANSIENT_ERRNOS


def _resolve(address: Address) -> Address:
    """Resolve a host name once, so ``sendto`` does not look it up per datagram."""
    host, port = address
    try:
        return socket.gethostbyname(host), int(port)
    except OSError as err:
        raise UdpError(f"UdpEndpoint: cannot resolve host {host!r}: {err}") from err
