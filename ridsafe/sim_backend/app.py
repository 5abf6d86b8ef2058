"""The sim backend as a process: ``SimBackend`` behind real UDP sockets (SITL-style ports).

Vehicle i (1-based):
- companion link: the sim binds ``host:(companion_base + 10 (i - 1))`` and answers whoever
  sends there (a companion connects with ``udpout:127.0.0.1:5760`` for vehicle 1);
- ground-station stream: the sim sends to ``host:(gcs_out_base + 10 (i - 1))`` from an
  ephemeral port and takes commands from whoever answers, like SITL's ``--out``
  (``mavproxy.py --master udpin:127.0.0.1:14550`` or pymavlink's ``udpin:``).
"""

from __future__ import annotations

import logging

from ridsafe.common.clock import MonotonicClock
from ridsafe.common.runner import UdpRunner
from ridsafe.common.udp import UdpEndpoint
from ridsafe.sim_backend.config import SimPorts
from ridsafe.sim_backend.world import EndpointKind, SimBackend

logger = logging.getLogger(__name__)


def open_endpoints(backend: SimBackend, ports: SimPorts) -> dict[str, UdpEndpoint]:
    """One socket per backend endpoint, bound and addressed per ``ports``."""
    sockets: dict[str, UdpEndpoint] = {}
    try:
        for name, endpoint in backend.endpoints.items():
            if endpoint.kind is EndpointKind.COMPANION:
                sockets[name] = UdpEndpoint(ports.host, ports.companion_port(endpoint.sysid))
            else:
                remote = (ports.host, ports.gcs_out_port(endpoint.sysid))
                sockets[name] = UdpEndpoint(ports.host, 0, remote=remote)
    except OSError:
        for sock in sockets.values():
            sock.close()
        raise
    return sockets


def describe_ports(backend: SimBackend, ports: SimPorts) -> list[str]:
    """Human-readable lines: where each vehicle listens and streams."""
    lines = []
    for sysid in range(1, backend.n_vehicles + 1):
        role = "spoofer" if backend.spoofer_index == sysid - 1 else "vehicle"
        parts = [f"{role} {sysid} ({backend.scenario.serial_of(sysid)}):"]
        if any(e.sysid == sysid and e.kind is EndpointKind.GCS for e in backend.endpoints.values()):
            parts.append(f"streams to udpin:{ports.host}:{ports.gcs_out_port(sysid)}")
        if any(
            e.sysid == sysid and e.kind is EndpointKind.COMPANION
            for e in backend.endpoints.values()
        ):
            parts.append(f"companion at udpout:{ports.host}:{ports.companion_port(sysid)}")
        lines.append(" ".join(parts))
    return lines


def make_runner(
    backend: SimBackend, ports: SimPorts, speed: float = 1.0, tick_s: float = 0.01
) -> UdpRunner:
    return UdpRunner(backend, open_endpoints(backend, ports), MonotonicClock(speed), tick_s)
