"""An in-memory byte router: sans-I/O cores advanced in lockstep by one clock.

The lockstep run mode wires the same cores the UDP runners drive (sim backend, companions,
GCS) with ``Wire``s between (core, endpoint) pairs and moves the same MAVLink bytes between
them, in a fixed order, so a run is deterministic for a seed and as fast as the CPU allows.

Each ``step(now_s)`` calls every core once, in ``order``; what a core sends is delivered to
cores later in the order within the same step and to earlier ones at the next step (one
tick of latency, like a datagram crossing a loopback socket between two polls).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ridsafe.common.shell import Datagrams, SansIoCore

Port = tuple[str, str]  # (core name, endpoint name)


@dataclass(frozen=True)
class Wire:
    """A bidirectional link between two (core, endpoint) ports."""

    a: Port
    b: Port


class ByteRouter:
    def __init__(
        self, cores: Mapping[str, SansIoCore], wires: Sequence[Wire], order: Sequence[str]
    ) -> None:
        unknown = [name for name in order if name not in cores]
        if unknown or set(order) != set(cores):
            raise ValueError(f"order must list every core once; unknown {unknown}")
        self.cores = dict(cores)
        self.order = list(order)
        self._route: dict[Port, Port] = {}
        for wire in wires:
            for port in (wire.a, wire.b):
                if port[0] not in cores:
                    raise ValueError(f"wire {wire} names unknown core {port[0]!r}")
                if port in self._route:
                    raise ValueError(f"port {port} is wired twice")
            self._route[wire.a] = wire.b
            self._route[wire.b] = wire.a
        self._inbox: dict[str, Datagrams] = {name: [] for name in cores}
        self.delivered = 0
        self.undeliverable = 0

    def step(self, now_s: float) -> None:
        for name in self.order:
            inbound, self._inbox[name] = self._inbox[name], []
            for endpoint, data in self.cores[name].handle(now_s, inbound):
                dest = self._route.get((name, endpoint))
                if dest is None:
                    self.undeliverable += 1
                    continue
                self._inbox[dest[0]].append((dest[1], data))
                self.delivered += 1

    def destination(self, core: str, endpoint: str) -> Port | None:
        """Where what ``core`` sends on ``endpoint`` arrives (None: nothing is wired there)."""
        return self._route.get((core, endpoint))

    def drop_inbox(self, core: str) -> int:
        """Discard what is queued for ``core`` (a dead peer); returns how many datagrams."""
        dropped = len(self._inbox[core])
        self._inbox[core] = []
        return dropped
