"""The companion app as a process: ``Companion`` cores behind real UDP sockets.

Per aircraft two endpoints, named by pymavlink-style connection strings:

- ``autopilot``: default ``udpout:127.0.0.1:(5760 + 10 (sysid - 1))``, the sim's companion
  port for that vehicle (ArduPilot SITL's instance convention); a real flight controller's
  UDP port works the same way.
- ``gcs``: default ``udpout:127.0.0.1:14450``, the ground station; every companion sends there
  from its own port, and the GCS answers each at the address it came from.

Several companions share one process and one runner through ``CompanionFleet``, which is
itself a sans-I/O core: endpoint ``"v{sysid}/autopilot"`` of the fleet is endpoint
``"autopilot"`` of companion ``sysid``. A GCS that is not there yet costs nothing but counted
send errors (``UdpEndpoint.stats``); the companions keep sending.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from ridsafe.common.clock import MonotonicClock
from ridsafe.common.errors import UdpError
from ridsafe.common.runner import RunnerClock, UdpRunner
from ridsafe.common.shell import Datagrams
from ridsafe.common.udp import UdpEndpoint
from ridsafe.companion.companion import AUTOPILOT, GCS, Companion

__all__ = [
    "DEFAULT_GCS_CONNECTION",
    "CompanionApp",
    "CompanionFleet",
    "Connections",
    "default_autopilot_connection",
    "fleet_endpoint",
]

logger = logging.getLogger(__name__)

DEFAULT_AUTOPILOT_BASE_PORT = 5760
INSTANCE_STEP = 10
DEFAULT_GCS_CONNECTION = "udpout:127.0.0.1:14450"


def default_autopilot_connection(
    sysid: int, base_port: int = DEFAULT_AUTOPILOT_BASE_PORT, host: str = "127.0.0.1"
) -> str:
    """The sim's (and SITL's) companion port of vehicle ``sysid``."""
    return f"udpout:{host}:{base_port + INSTANCE_STEP * (sysid - 1)}"


@dataclass(frozen=True)
class Connections:
    """Connection strings of one companion's two endpoints."""

    autopilot: str
    gcs: str = DEFAULT_GCS_CONNECTION


def fleet_endpoint(sysid: int, endpoint: str) -> str:
    return f"v{sysid}/{endpoint}"


class CompanionFleet:
    """Several companions as one sans-I/O core (endpoint ``v{sysid}/{autopilot|gcs}``)."""

    def __init__(self, companions: Sequence[Companion]) -> None:
        self.companions = {c.spec.sysid: c for c in companions}
        if len(self.companions) != len(companions):
            raise ValueError("two companions share a system id")
        self.unknown_endpoint = 0
        self.t_s = 0.0

    def handle(self, now_s: float, inbound: Datagrams) -> Datagrams:
        per: dict[int, Datagrams] = {sysid: [] for sysid in self.companions}
        for name, data in inbound:
            target = self._route(name)
            if target is None:
                self.unknown_endpoint += 1
                continue
            per[target[0]].append((target[1], data))
        self.t_s = now_s
        return self._collect(lambda c: c.handle(now_s, per[c.spec.sysid]))

    def count_foreign(self, name: str, reason: str, count: int = 1) -> None:
        """``count`` datagrams the runner dropped on ``name`` (``common.runner``), counted by
        the companion whose endpoint it is."""
        target = self._route(name)
        if target is None:
            self.unknown_endpoint += count
            return
        self.companions[target[0]].shell.count_foreign(target[1], reason, count)

    def finish(self, now_s: float) -> Datagrams:
        return self._collect(lambda c: c.finish(max(now_s, c.t_s)))

    def _collect(self, call: Callable[[Companion], Datagrams]) -> Datagrams:
        out: Datagrams = []
        for sysid, companion in self.companions.items():
            out.extend((fleet_endpoint(sysid, name), data) for name, data in call(companion))
        return out

    def _route(self, name: str) -> tuple[int, str] | None:
        prefix, _, endpoint = name.partition("/")
        if not prefix.startswith("v") or endpoint not in (AUTOPILOT, GCS):
            return None
        try:
            sysid = int(prefix[1:])
        except ValueError:
            return None
        return (sysid, endpoint) if sysid in self.companions else None


def open_endpoints(connections: Mapping[int, Connections]) -> dict[str, UdpEndpoint]:
    """One socket per companion endpoint (closed again if any fails to open)."""
    sockets: dict[str, UdpEndpoint] = {}
    try:
        for sysid, conn in connections.items():
            sockets[fleet_endpoint(sysid, AUTOPILOT)] = UdpEndpoint.from_spec(conn.autopilot)
            sockets[fleet_endpoint(sysid, GCS)] = UdpEndpoint.from_spec(conn.gcs)
    except Exception:
        for sock in sockets.values():
            sock.close()
        raise
    return sockets


class CompanionApp:
    """Companions + sockets + a runner; ``run`` until stopped, then ``finish`` every core."""

    def __init__(
        self,
        companions: Sequence[Companion],
        connections: Mapping[int, Connections],
        speed: float = 1.0,
        tick_s: float = 0.01,
        clock: RunnerClock | None = None,
    ) -> None:
        """``clock``: the runner's time (default: ``speed`` times the time since now)."""
        missing = sorted({c.spec.sysid for c in companions} - set(connections))
        if missing:
            raise ValueError(f"no connections for companions {missing}")
        self.fleet = CompanionFleet(companions)
        self.endpoints = open_endpoints(connections)
        runner_clock = clock if clock is not None else MonotonicClock(speed)
        self.runner = UdpRunner(self.fleet, self.endpoints, runner_clock, tick_s)

    def run(
        self, until_s: float | None = None, on_tick: Callable[[float], None] | None = None
    ) -> float:
        """Run until ``stop()`` or ``until_s`` sim seconds; always finishes the cores."""
        last_s = 0.0
        try:
            last_s = self.runner.run(until_s, on_tick)
        finally:
            self._finish(max(last_s, self.fleet.t_s))
        return last_s

    def stop(self) -> None:
        self.runner.stop()

    def close(self) -> None:
        self.runner.close()

    def _finish(self, now_s: float) -> None:
        for name, data in self.fleet.finish(now_s):
            endpoint = self.endpoints.get(name)
            if endpoint is None or endpoint.closed or endpoint.destination is None:
                continue
            try:
                endpoint.send(data)
            except UdpError as exc:
                logger.warning("final datagram to %s not sent: %s", name, exc)
