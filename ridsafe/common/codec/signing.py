"""MAVLink 2 message signing: the key, the outgoing timestamp and the per-stream replay check.

A signed packet ends with ``link_id(1) timestamp(6) signature(6)``, the signature being the
first 6 bytes of SHA-256(key + the packet up to and including the timestamp). Timestamps
count 10 us units since 2015-01-01T00:00:00Z and must grow per stream; a stream is
(link id, system, component), as the MAVLink signing specification and pymavlink's
``check_signature`` keep it.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common.errors import WireError

SIGNING_EPOCH_UNIX_S = 1420070400
#: A new stream may start at most this far (10 us units: one minute) behind the link's clock.
NEW_STREAM_SLACK = 6000 * 1000


@dataclass(frozen=True)
class SigningConfig:
    """MAVLink 2 signing: 32-byte secret key and the first outgoing timestamp."""

    key: bytes = field(repr=False)
    initial_timestamp: int = 0
    link_id: int = 0

    def __post_init__(self) -> None:
        if len(self.key) != 32:
            raise ValueError(f"signing key must be 32 bytes, got {len(self.key)}")


def signing_timestamp_from_unix(unix_s: float) -> int:
    """MAVLink signing timestamp (10 us units since 2015) for a UNIX time."""
    return max(0, int((unix_s - SIGNING_EPOCH_UNIX_S) * 100_000))


def load_signing_key(path: str | Path) -> bytes:
    """Read a signing key file: 64 hex characters, or a passphrase hashed with SHA-256
    (the convention MAVProxy's ``signing setup`` uses)."""
    text = Path(path).read_text(encoding="utf-8").strip()
    if not text:
        raise WireError(f"{path}: signing key file is empty")
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) == 32:
        return key
    return hashlib.sha256(text.encode("utf-8")).digest()


Stream = tuple[int, int, int]  # (link id, system, component)


@dataclass
class ReplayWindow:
    """Anti-replay state: the newest timestamp accepted per stream, and the receive clock.

    Kept per stream (link id, system, component), never per source address: a core that
    talks to many peers through one key (the GCS) shares one window between all its peer
    links, so a stream captured and re-sent from a new socket still carries old timestamps
    and is refused (``replayed`` / ``stale_new_stream``)."""

    timestamp: int = 0  # the newest timestamp accepted, or the owner's own clock
    stream_timestamps: dict[Stream, int] = field(default_factory=dict)
    replayed: int = 0
    stale_new_stream: int = 0


class SigningState:
    """One link's signing: signs what it sends, checks what it receives."""

    def __init__(self, config: SigningConfig, replay: ReplayWindow | None = None) -> None:
        self.config = config
        self.timestamp = config.initial_timestamp  # the link's clock: next outgoing stamp
        self.replay = replay if replay is not None else ReplayWindow()
        self.replay.timestamp = max(self.replay.timestamp, config.initial_timestamp)

    @property
    def stream_timestamps(self) -> dict[Stream, int]:
        return self.replay.stream_timestamps

    def sign(self, packet: bytes) -> bytes:
        """``packet`` (header to CRC) with its signature appended; advances the clock."""
        packet += struct.pack("<BQ", self.config.link_id, self.timestamp)[:7]
        self.timestamp += 1
        return packet + hashlib.sha256(self.config.key + packet).digest()[:6]

    def advance_to(self, timestamp: int) -> None:
        """Move the outgoing clock up to ``timestamp`` (never back). Stamps then follow
        time, as the signing specification asks, not only the packet count: a receiver
        that restarts with a clock-based start still finds the stream fresh."""
        self.timestamp = max(self.timestamp, timestamp)

    def genuine_and_fresh(self, packet: bytes, system: int, component: int) -> bool:
        """Would ``check`` accept ``packet`` now? Changes nothing (for vetting a sender
        before its address is trusted)."""
        expected = hashlib.sha256(self.config.key + packet[:-6]).digest()[:6]
        if expected != packet[-6:]:
            return False
        timestamp = int.from_bytes(packet[-12:-6], "little")
        last = self.replay.stream_timestamps.get((packet[-13], system, component))
        if last is not None:
            return timestamp > last
        return timestamp + NEW_STREAM_SLACK >= max(self.timestamp, self.replay.timestamp)

    def check(self, packet: bytes, system: int, component: int) -> str | None:
        """None if a signed ``packet`` is genuine and fresh, else why not. The signature is
        verified first, so a forged packet cannot advance a stream's timestamp and make
        genuine packets look replayed. Per stream the timestamp must grow; a new stream may
        be at most a minute behind this link's clock, which then moves up to the newest
        timestamp accepted."""
        expected = hashlib.sha256(self.config.key + packet[:-6]).digest()[:6]
        if expected != packet[-6:]:
            return f"forged signature from {system}/{component}"
        timestamp = int.from_bytes(packet[-12:-6], "little")
        stream = (packet[-13], system, component)
        window = self.replay
        last = window.stream_timestamps.get(stream)
        if last is not None and timestamp <= last:
            window.replayed += 1
            return f"replayed signature from {system}/{component}"
        if last is None and timestamp + NEW_STREAM_SLACK < max(self.timestamp, window.timestamp):
            window.stale_new_stream += 1
            return f"stale new stream from {system}/{component}"
        window.stream_timestamps[stream] = timestamp
        window.timestamp = max(window.timestamp, timestamp)
        self.timestamp = max(self.timestamp, timestamp)
        return None
