"""Peers earned, not taken (issue 14): the reply address of a listening endpoint is learned
only from a genuine frame, locked, and switched only after the old peer has been silent.

The UDP tests drive the real sim backend core through ``UdpRunner`` on 127.0.0.1 with a
companion socket, and spray at the sim's port from another socket."""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Callable

import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.clock import MonotonicClock
from ridsafe.common.peer_lock import PeerLock
from ridsafe.common.runner import UdpRunner
from ridsafe.common.udp import UdpEndpoint
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import EndpointKind, SimBackend
from tests.sim_backend.helpers import scenario

A, B = ("127.0.0.1", 4000), ("127.0.0.1", 4001)
COMPANION_IDS = (1, 191)
TICK_S = 0.05


def test_a_peer_is_learned_only_from_a_genuine_frame() -> None:
    lock = PeerLock("v1/companion")
    assert not lock.admit(0.0, A, set())  # garbage from A: not learned
    assert lock.address is None and lock.foreign == 1
    assert lock.admit(0.1, A, {COMPANION_IDS})
    assert lock.address == A


def test_a_locked_peer_is_kept_while_it_speaks_even_against_valid_frames() -> None:
    lock = PeerLock("v1/companion", switch_after_s=3.0)
    lock.admit(0.0, A, {COMPANION_IDS})
    for k in range(1, 100):
        t_s = 0.1 * k
        assert lock.admit(t_s, A, {COMPANION_IDS} if k % 10 == 0 else set())  # 1 Hz genuine
        assert not lock.admit(t_s, B, {COMPANION_IDS})
    assert lock.address == A and lock.switches == 0


def test_a_silent_peer_is_replaced_only_by_the_same_ids() -> None:
    lock = PeerLock("v1/companion", switch_after_s=3.0)
    lock.admit(0.0, A, {COMPANION_IDS})
    assert not lock.admit(2.9, B, {COMPANION_IDS})  # not silent long enough
    assert not lock.admit(5.0, B, {(7, 191)})  # silent, but another system
    assert lock.admit(5.0, B, {COMPANION_IDS})
    assert lock.address == B and lock.switches == 1


class SimOverUdp:
    """The sim backend's vehicle-1 companion port behind a ``UdpRunner``, a companion
    socket that sends a heartbeat every tick and counts telemetry, and whatever else the
    test does each tick (``extra``)."""

    def __init__(self, signing: codec.SigningConfig | None = None) -> None:
        """``signing``: the sim's companion port and the companion sign (ArduPilot's way)."""
        self.t_s = 0.0
        self.backend = SimBackend(
            scenario(1), SimConfig(), [EndpointKind.COMPANION], companion_signing=signing
        )
        self.port = UdpEndpoint()
        self.runner = UdpRunner(
            self.backend, {"v1/companion": self.port}, MonotonicClock(1.0, self._time), TICK_S
        )
        self.companion = UdpEndpoint(remote=self.port.local_address)
        self.link = codec.MavlinkLink(*COMPANION_IDS, signing)
        self.parser = codec.MavlinkLink(255, 190, signing)
        self.speaks = True  # the companion sends its heartbeat each tick
        self.telemetry = 0
        self.extra: Callable[[float], None] = lambda now_s: None

    def _time(self) -> float:
        return self.t_s

    def _tick(self, now_s: float) -> None:
        if self.speaks:
            self.companion.send(self.link.pack(m.Heartbeat(18, 8, 0, 0, 4)))
        self.extra(now_s)
        time.sleep(0.002)  # loopback delivery before the next drain
        for data, _ in self.companion.recv_all():
            got = self.parser.feed(data)
            self.telemetry += sum(isinstance(r.message, m.GlobalPositionInt) for r in got)
        self.t_s = (round(now_s / TICK_S) + 1) * TICK_S + 1e-6  # the next tick, surely

    def run(self, until_s: float) -> int:
        self.runner.run(until_s, self._tick)
        return self.telemetry

    def close(self) -> None:
        self.runner.close()
        self.companion.close()


@pytest.mark.udp
def test_random_bytes_sprayed_at_the_sim_port_do_not_reduce_the_companions_telemetry() -> None:
    clean = SimOverUdp()
    try:
        clean_count = clean.run(6.0)
    finally:
        clean.close()
    rng = random.Random(14)
    sprayed = SimOverUdp()
    attacker = UdpEndpoint(remote=sprayed.port.local_address)
    forger = codec.MavlinkLink(*COMPANION_IDS)  # valid MAVLink with the companion's ids

    def spray(now_s: float) -> None:
        for _ in range(20):
            attacker.send(rng.randbytes(rng.randint(1, 300)))
        attacker.send(forger.pack(m.Heartbeat(18, 8, 0, 0, 4)))

    sprayed.extra = spray
    try:
        count = sprayed.run(6.0)
        lock = sprayed.runner.locks["v1/companion"]
        assert lock.address == sprayed.companion.local_address
        assert lock.switches == 0 and lock.foreign >= 21 * 100
        assert sprayed.port.destination == sprayed.companion.local_address
        # and every datagram the lock dropped is in the sim's /app/counters too
        counters = sprayed.runner.core.counter_values()  # type: ignore[attr-defined]
        assert counters["not_from_locked_peer"] == lock.foreign
    finally:
        sprayed.close()
        attacker.close()
    assert clean_count > 40  # GLOBAL_POSITION_INT at ~10 Hz for 6 s
    assert count >= 0.95 * clean_count


@pytest.mark.udp
def test_a_restarted_companion_from_a_new_port_takes_over_after_the_silence() -> None:
    sim = SimOverUdp()
    try:
        sim.run(2.0)
        first = sim.companion.local_address
        sim.companion.close()
        sim.companion = UdpEndpoint(remote=sim.port.local_address)  # restarted: new port
        sim.link = codec.MavlinkLink(*COMPANION_IDS)
        sim.telemetry = 0
        sim.run(6.0)  # 3 s of the new socket's heartbeats unanswered, then served
        lock = sim.runner.locks["v1/companion"]
        assert lock.address == sim.companion.local_address != first
        assert lock.switches == 1 and sim.telemetry > 0
    finally:
        sim.close()


class _Echo:
    """A core that records what it is handed on its one endpoint."""

    def __init__(self) -> None:
        self.got: list[bytes] = []

    def handle(self, now_s: float, inbound: list[tuple[str, bytes]]) -> list[tuple[str, bytes]]:
        self.got.extend(data for _, data in inbound)
        return []


def _run_for_a_second(
    core: _Echo, name: str, endpoint: UdpEndpoint, each_tick: Callable[[float], None]
) -> UdpRunner:
    """Run ``core`` on ``endpoint`` (as ``name``) for 1 s of ticks, ``each_tick(now_s)`` after
    every tick, on a clock that steps one tick per tick; the runner is closed and returned."""
    clock_s = [0.0]

    def tick(now_s: float) -> None:
        each_tick(now_s)
        time.sleep(0.002)
        clock_s[0] = (round(now_s / TICK_S) + 1) * TICK_S + 1e-6

    runner = UdpRunner(core, {name: endpoint}, MonotonicClock(1.0, lambda: clock_s[0]), TICK_S)
    try:
        runner.run(1.0, tick)
    finally:
        runner.close()
    return runner


@pytest.mark.udp
def test_a_udpout_endpoint_takes_datagrams_from_its_remote_only() -> None:
    remote = UdpEndpoint()
    out = UdpEndpoint(remote=remote.local_address)
    stranger = UdpEndpoint(remote=out.local_address)
    out.send(b"hello")  # so the remote knows where out is
    remote.recv_all()

    def each_tick(_now_s: float) -> None:
        remote.send(b"from the remote", out.local_address)
        stranger.send(b"from a stranger")

    core = _Echo()
    try:
        runner = _run_for_a_second(core, "autopilot", out, each_tick)
    finally:
        remote.close()
        stranger.close()
    assert core.got and set(core.got) == {b"from the remote"}
    assert runner.stats.foreign_dropped >= 15


class _Counting(_Echo):
    """Records what the runner says it dropped before the core."""

    def __init__(self) -> None:
        super().__init__()
        self.foreign: dict[str, int] = {}

    def count_foreign(self, name: str, reason: str, count: int = 1) -> None:
        self.foreign[f"{name}.{reason}"] = self.foreign.get(f"{name}.{reason}", 0) + count


@pytest.mark.udp
@pytest.mark.skipif(sys.platform != "linux", reason="SO_RXQ_OVFL is Linux's")
def test_datagrams_the_kernel_dropped_reach_the_cores_counters() -> None:
    """A flood into a small receive buffer before the runner reads: what the core got plus
    what it was told the kernel dropped is everything sent (loopback loses nothing else)."""
    port = UdpEndpoint(recv_buffer_bytes=4096)
    sender = UdpEndpoint(remote=port.local_address)
    for i in range(400):
        sender.send(i.to_bytes(4, "big") * 64)

    sent = [400]

    def each_tick(now_s: float) -> None:  # the drop count comes with a later datagram
        if now_s < 0.5:  # and the runner reads every one of them before it stops
            sent[0] += sender.send(b"after the flood")

    core = _Counting()
    try:
        runner = _run_for_a_second(core, "gcs", port, each_tick)
    finally:
        sender.close()
    dropped = core.foreign.get("gcs.kernel_overflow", 0)
    assert dropped > 0
    assert len(core.got) + dropped == sent[0]
    assert runner.stats.kernel_dropped == dropped
