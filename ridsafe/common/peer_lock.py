"""Which address a listening endpoint answers: earned by a genuine frame, held while it speaks.

A ``udpin`` endpoint (the sim's companion ports, a flight controller's UDP port) has no fixed
peer; pymavlink's rule, "reply to whoever sent last", lets any local process redirect the
telemetry with one datagram of garbage. ``PeerLock`` replaces it:

- **learned only from a genuine frame**: a datagram's source address can become the peer only
  if the datagram holds a frame with a known id, a matching CRC and (on a signed link) a
  genuine, fresh signature, from a (system, component) the endpoint's sender check admits
  (``SansIoCore.valid_senders``);
- **locked**: once learned, the peer stays; datagrams from any other address are dropped
  before the core sees them (counted ``foreign``);
- **switched only after silence**: another address takes over only with a genuine frame from
  the same (system, component) as the locked peer, and only after the locked peer has sent
  no genuine frame for ``switch_after_s`` (counted ``switches``, logged).

Why that is safe: a live peer sends genuine frames at least every second (HEARTBEAT at 1 Hz,
setpoints and telemetry faster), so while it lives ``switch_after_s`` (default 3 s, the
companion's autopilot timeout) never elapses and no other address can take the link, valid
frames or not. Only a peer that has gone quiet (a crashed or restarted process, which comes
back from a new port) can be replaced, and then only by frames the link would accept anyway;
on a signed link an attacker without the key cannot produce one, and a replayed one is not
fresh. Without signing, an attacker who speaks MAVLink can take over a link that is already
dead, which loses nothing that was not lost.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from ridsafe.common.udp import Address

__all__ = ["DEFAULT_SWITCH_AFTER_S", "PeerLock"]

logger = logging.getLogger(__name__)

DEFAULT_SWITCH_AFTER_S = 3.0

Sender = tuple[int, int]  # (system, component)


@dataclass
class PeerLock:
    """The locked peer of one listening endpoint (see the module docstring)."""

    name: str
    switch_after_s: float = DEFAULT_SWITCH_AFTER_S
    address: Address | None = None
    senders: set[Sender] = field(default_factory=set)
    last_genuine_s: float = 0.0
    foreign: int = 0  # datagrams from another address, dropped
    switches: int = 0

    def admit(self, now_s: float, address: Address, senders: set[Sender]) -> bool:
        """Whether a datagram from ``address``, holding genuine frames from ``senders``, goes
        to the core; learns or switches the peer as the rules say."""
        if address == self.address:
            if senders:
                self.last_genuine_s = now_s
            return True
        if not senders:
            self.foreign += 1
            return False
        if self.address is None:
            logger.info("%s: peer %s:%d learned (senders %s)", self.name, *address, senders)
            self._lock(now_s, address, senders)
            return True
        quiet_s = now_s - self.last_genuine_s
        if senders & self.senders and quiet_s >= self.switch_after_s:
            logger.warning(
                "%s: peer %s:%d silent for %.1f s; switched to %s:%d",
                self.name,
                *self.address,
                quiet_s,
                *address,
            )
            self.switches += 1
            self._lock(now_s, address, senders & self.senders)
            return True
        self.foreign += 1
        return False

    def _lock(self, now_s: float, address: Address, senders: set[Sender]) -> None:
        self.address, self.last_genuine_s = address, now_s
        self.senders = set(senders)
