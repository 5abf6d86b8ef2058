"""Drive a sans-I/O core over real UDP sockets in (scaled) real time.

A core is anything with ``handle(now_s, inbound) -> outbound`` where inbound and outbound
are ``(endpoint_name, datagram)`` pairs. ``UdpRunner`` owns one ``UdpEndpoint`` per endpoint
name; every ``tick_s`` of sim time (``tick_s / speed`` of wall time) it drains every socket,
calls the core once with everything that arrived, and sends what the core returns. Sockets
live here and nowhere else.

An endpoint with a fixed remote (``udpout``) always sends there, and takes datagrams from
there only (others are dropped, counted in ``foreign_dropped`` and, as ``not_from_remote``,
in the core's refused counters: a local process cannot talk to a companion through its
ephemeral port). One without (``udpin``) replies to its peer: with a core that can vet
senders (``valid_senders(name, data)``, as ``AppShell`` does) the peer is earned by a
genuine frame and locked (``common.peer_lock``: datagrams from other addresses are dropped
and counted, as ``not_from_locked_peer`` in the core's counters too, and the peer switches
only after ``switch_after_s`` of silence); with a core that cannot, the last address heard
(pymavlink's rule). Until a peer is known, what the core sends there is counted in
``unsent_no_peer`` and dropped, as a
serial port with nothing attached would drop it.

A multi-peer endpoint (named in ``multi_peer``) is one socket that many peers talk to, like
a ground station's 14550: what arrives from ``host:port`` is handed to the core as
``"name@host:port"``, and what the core returns for ``"name@host:port"`` is sent to that
address (a malformed address is counted in ``unsent_bad_peer`` and dropped). Plain
``"name"`` still means "the last peer heard".

An app calls ``freeze_startup_objects`` once its core is built, before the run's start
instant: every object that exists then (modules, compiled kernels, the core) lives for the
whole run, and a full collection would otherwise walk them all inside whichever ``handle``
call it interrupts (over 100 ms in a fuzz campaign; issue 14).
"""

from __future__ import annotations

import gc
import ipaddress
import logging
import selectors
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import Protocol

from ridsafe.common.errors import UdpError
from ridsafe.common.peer_lock import DEFAULT_SWITCH_AFTER_S, PeerLock
from ridsafe.common.shell import AppShell, Datagrams, SansIoCore
from ridsafe.common.udp import Address, UdpEndpoint

logger = logging.getLogger(__name__)

PEER_SEPARATOR = "@"
#: The reason a core's counters give the datagrams the kernel dropped on a full buffer.
KERNEL_OVERFLOW = "kernel_overflow"
_MAX_CACHED_PEERS = 4096


def freeze_startup_objects() -> None:
    """Collect once, then exempt every surviving object from later collections
    (``gc.freeze``): what a process built before its loop is not garbage, and walking it in
    each full collection is a pause of tens of milliseconds per 100,000 objects."""
    gc.collect()
    gc.freeze()


class RunnerClock(Protocol):
    """What the runner needs of a clock (``MonotonicClock`` is one): sim time now, and the
    wall time to wait for some sim time to pass."""

    def now_s(self) -> float: ...

    def wall_delay_s(self, sim_dt_s: float) -> float: ...


@dataclass
class RunnerStats:
    ticks: int = 0
    datagrams_in: int = 0
    datagrams_out: int = 0
    unsent_no_peer: int = 0
    unknown_endpoint_out: int = 0
    late_ticks: int = 0
    unsent_bad_peer: int = 0
    foreign_dropped: int = 0  # datagrams from an address that is not the endpoint's peer
    kernel_dropped: int = 0  # datagrams the kernel dropped for a full receive buffer


class UdpRunner:
    """Runs ``core`` against ``endpoints`` until ``stop()`` or ``until_s`` of sim time."""

    def __init__(
        self,
        core: SansIoCore,
        endpoints: Mapping[str, UdpEndpoint],
        clock: RunnerClock,
        tick_s: float = 0.01,
        multi_peer: Collection[str] = (),
        switch_after_s: float = DEFAULT_SWITCH_AFTER_S,
    ) -> None:
        if tick_s <= 0:
            raise ValueError(f"tick_s must be > 0, got {tick_s}")
        unknown = sorted(set(multi_peer) - set(endpoints))
        if unknown:
            raise ValueError(f"multi_peer names {unknown} are not endpoints ({sorted(endpoints)})")
        self.multi_peer = frozenset(multi_peer)
        self._peer_names: dict[Address, str] = {}
        self._peer_addresses: dict[str, Address | None] = {}
        self.core = core
        self.endpoints = dict(endpoints)
        self.clock = clock
        self.tick_s = tick_s
        self.stats = RunnerStats()
        self._kernel_drops_seen: dict[str, int] = {}
        self._stopping = False
        self._selector = selectors.DefaultSelector()
        for name, endpoint in self.endpoints.items():
            self._selector.register(endpoint.fileno(), selectors.EVENT_READ, name)
        vet = getattr(core, "valid_senders", None)
        self._vet: Callable[[str, bytes], set[tuple[int, int]]] | None = vet
        self._count_foreign = _foreign_counter(core)
        self.locks: dict[str, PeerLock] = {}
        if vet is not None:
            for name, endpoint in self.endpoints.items():
                if endpoint.remote is None and name not in self.multi_peer:
                    endpoint.learns_peer = False
                    self.locks[name] = PeerLock(name, switch_after_s)

    def stop(self) -> None:
        self._stopping = True

    def run(
        self,
        until_s: float | None = None,
        on_tick: Callable[[float], None] | None = None,
    ) -> float:
        """Loop until stopped or ``until_s``; returns the last sim time handled."""
        now_s = 0.0
        next_tick_s = 0.0
        while not self._stopping and (until_s is None or now_s < until_s):
            wait_s = self.clock.wall_delay_s(next_tick_s - self.clock.now_s())
            if wait_s > 0:
                self._selector.select(timeout=wait_s)
            now_s = self.clock.now_s()
            if now_s < next_tick_s:
                continue
            if now_s - next_tick_s > 5 * self.tick_s:
                self.stats.late_ticks += 1
            if until_s is not None:
                now_s = min(now_s, until_s)
            self._step(now_s)
            next_tick_s = (int(now_s / self.tick_s) + 1) * self.tick_s
            if on_tick is not None:
                on_tick(now_s)
        return now_s

    def _step(self, now_s: float) -> None:
        inbound: Datagrams = []
        for name, endpoint in self.endpoints.items():
            multi = name in self.multi_peer
            for data, addr in endpoint.recv_all():
                if not self._admit(now_s, name, endpoint, data, addr):
                    self.stats.foreign_dropped += 1
                    if self._count_foreign is not None:
                        self._count_foreign(name, _foreign_reason(endpoint), 1)
                    continue
                inbound.append((self._peer_name(name, addr) if multi else name, data))
            self._count_kernel_drops(name, endpoint)
        self.stats.datagrams_in += len(inbound)
        outbound = self.core.handle(now_s, inbound)
        for name, data in outbound:
            self._send(name, data)
        self.stats.ticks += 1

    def _count_kernel_drops(self, name: str, endpoint: UdpEndpoint) -> None:
        """The datagrams the kernel dropped on ``name`` since the last look, counted as
        ``kernel_overflow`` with the core's other drops (``UdpStats.kernel_drops``)."""
        new = endpoint.stats.kernel_drops - self._kernel_drops_seen.get(name, 0)
        if new > 0:
            self._kernel_drops_seen[name] = endpoint.stats.kernel_drops
            self.stats.kernel_dropped += new
            if self._count_foreign is not None:
                self._count_foreign(name, KERNEL_OVERFLOW, new)

    def _admit(
        self, now_s: float, name: str, endpoint: UdpEndpoint, data: bytes, addr: Address
    ) -> bool:
        """Whether a datagram from ``addr`` goes to the core (see the module docstring)."""
        if endpoint.remote is not None:
            return addr == endpoint.remote
        lock = self.locks.get(name)
        if lock is None or self._vet is None:
            return True
        senders = self._vet(name, data)
        admitted = lock.admit(now_s, addr, senders)
        if admitted and lock.address is not None and endpoint.peer != lock.address:
            endpoint.set_peer(lock.address)
        return admitted

    def _peer_name(self, name: str, addr: Address) -> str:
        peer = self._peer_names.get(addr)
        if peer is None:
            if len(self._peer_names) >= _MAX_CACHED_PEERS:
                self._peer_names.clear()
            peer = f"{addr[0]}:{addr[1]}"
            self._peer_names[addr] = peer
        return f"{name}{PEER_SEPARATOR}{peer}"

    def _peer_address(self, peer: str) -> Address | None:
        if peer not in self._peer_addresses:
            if len(self._peer_addresses) >= _MAX_CACHED_PEERS:
                self._peer_addresses.clear()
            self._peer_addresses[peer] = parse_peer(peer)
        return self._peer_addresses[peer]

    def _send(self, name: str, data: bytes) -> None:
        endpoint = self.endpoints.get(name)
        addr: Address | None = None
        if endpoint is None:
            base, _, peer = name.partition(PEER_SEPARATOR)
            if base not in self.multi_peer:
                self.stats.unknown_endpoint_out += 1
                return
            endpoint, addr = self.endpoints[base], self._peer_address(peer)
            if addr is None:
                self.stats.unsent_bad_peer += 1
                return
        elif endpoint.destination is None:
            self.stats.unsent_no_peer += 1
            return
        try:
            if endpoint.send(data, addr):
                self.stats.datagrams_out += 1
        except UdpError as exc:
            self.stats.unsent_no_peer += 1
            logger.debug("%s: %s", name, exc)

    def close(self) -> None:
        self._selector.close()
        for endpoint in self.endpoints.values():
            endpoint.close()


def parse_peer(peer: str) -> Address | None:
    """``"a.b.c.d:port"`` (as the runner names peers) -> (host, port), or None if malformed."""
    host, sep, port = peer.rpartition(":")
    if not sep or not port.isdigit() or not 1 <= int(port) <= 65535:
        return None
    try:
        ipaddress.IPv4Address(host)
    except ValueError:
        return None
    return host, int(port)


def _foreign_counter(core: SansIoCore) -> Callable[[str, str, int], None] | None:
    """Where the core counts what the runner drops before it (for ``/app/counters``): its
    own ``count_foreign(name, reason, count)``, else its ``AppShell``'s, else nowhere."""
    counter = getattr(core, "count_foreign", None)
    if callable(counter):
        return counter  # type: ignore[no-any-return]
    shell = getattr(core, "shell", None)
    return shell.count_foreign if isinstance(shell, AppShell) else None


def _foreign_reason(endpoint: UdpEndpoint) -> str:
    return "not_from_remote" if endpoint.remote is not None else "not_from_locked_peer"
