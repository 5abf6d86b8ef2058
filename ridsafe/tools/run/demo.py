"""A minimal MAVLink ground station on one UDP socket, for the demo flight (``ridsafe demo``).

Our codec and blocking helpers: wait for a condition on the latest message of each type,
send a ``COMMAND_LONG`` and wait for its ``COMMAND_ACK``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.udp import UdpEndpoint

__all__ = ["GroundStation"]


class GroundStation:
    """A minimal MAVLink ground station on one UDP socket (our codec, blocking helpers)."""

    def __init__(self, endpoint: UdpEndpoint, sysid: int, timeout_wall_s: float = 30.0) -> None:
        self.endpoint = endpoint
        self.link = codec.MavlinkLink(255, 190)
        self.sysid = sysid
        self.timeout_wall_s = timeout_wall_s
        self.latest: dict[type, m.Message] = {}
        self.texts: list[str] = []

    def poll(self) -> None:
        for data, _addr in self.endpoint.recv_all():
            for received in self.link.feed(data):
                if received.src_system != self.sysid:
                    continue
                self.latest[type(received.message)] = received.message
                if isinstance(received.message, m.StatusText):
                    self.texts.append(received.message.text)

    def wait_for(self, what: str, predicate: Callable[[], bool]) -> None:
        deadline = time.monotonic() + self.timeout_wall_s
        while not predicate():
            if time.monotonic() > deadline:
                raise TimeoutError(f"timed out waiting for {what}")
            time.sleep(0.01)
            self.poll()

    def send(self, message: m.Message) -> None:
        self.endpoint.send(self.link.pack(message))

    def command(self, command: int, *params: float) -> int:
        padded = (tuple(params) + (0.0,) * 7)[:7]
        self.latest.pop(m.CommandAck, None)
        self.send(m.CommandLong(self.sysid, 1, command, 0, padded))  # type: ignore[arg-type]
        self.wait_for(f"COMMAND_ACK {command}", lambda: m.CommandAck in self.latest)
        ack = self.latest[m.CommandAck]
        assert isinstance(ack, m.CommandAck)
        return ack.result

    def local_position(self) -> m.LocalPositionNed | None:
        msg = self.latest.get(m.LocalPositionNed)
        return msg if isinstance(msg, m.LocalPositionNed) else None

    def heartbeat(self) -> m.Heartbeat | None:
        msg = self.latest.get(m.Heartbeat)
        return msg if isinstance(msg, m.Heartbeat) else None
