"""The GCS as a process: the ``Gcs`` core behind one UDP port that every companion talks to.

Companions send to ``127.0.0.1:14450`` (by default; any ``udpin:HOST:PORT``); the runner names
each sender ``companions@host:port`` and sends regions, alerts and heartbeats back to every
live one from the same port, like a ground station on 14550.
"""

from __future__ import annotations

from ridsafe.common.clock import EpochClock, MonotonicClock
from ridsafe.common.errors import ConnectionStringError
from ridsafe.common.runner import RunnerClock, UdpRunner
from ridsafe.common.udp import ConnectionSpec, UdpEndpoint, parse_connection_string
from ridsafe.gcs.gcs import COMPANIONS_ENDPOINT, Gcs

DEFAULT_LISTEN = "udpin:127.0.0.1:14450"
#: Runner tick (sim seconds): reports are parsed this often; the cycle runs every cycle_s.
DEFAULT_TICK_S = 0.05


def listen_spec(text: str | ConnectionSpec) -> ConnectionSpec:
    """A listening connection string (``udpin:`` / ``udp:``); ``udpout`` is refused, since
    the GCS waits for its companions to speak first."""
    spec = parse_connection_string(text) if isinstance(text, str) else text
    if not spec.mode.listens:
        raise ConnectionStringError(
            f"GCS listen address {spec}: expected udpin:HOST:PORT (the GCS has one port that "
            "every companion sends to)"
        )
    return spec


def make_runner(
    gcs: Gcs,
    listen: str | ConnectionSpec = DEFAULT_LISTEN,
    speed: float = 1.0,
    tick_s: float = DEFAULT_TICK_S,
    t0_unix: float | None = None,
) -> UdpRunner:
    """A runner for ``gcs`` with one multi-peer endpoint bound to ``listen``; sim time from
    this call on, or from ``t0_unix`` (a start instant shared with the other processes)."""
    clock: RunnerClock = MonotonicClock(speed) if t0_unix is None else EpochClock(speed, t0_unix)
    endpoint = UdpEndpoint.from_spec(listen_spec(listen))
    try:
        return UdpRunner(
            gcs, {COMPANIONS_ENDPOINT: endpoint}, clock, tick_s, multi_peer={COMPANIONS_ENDPOINT}
        )
    except Exception:
        endpoint.close()
        raise
