"""Mutations of captured MAVLink datagrams, as a hostile local process would make them.

Two families, chosen at random per input (``Mutator.mutate``):

- **bytes**: flip bits, overwrite or insert bytes, truncate, splice two datagrams, repeat a
  packet, or plain random bytes; most die at the CRC, which is the point of some of them;
- **fields**: pick one packet of the datagram, unpack its payload with the message's own
  struct, set one field to an extreme of its type (NaN, +-inf, +-3.4e38 and 1e30 for
  floats; 0, the minimum and the maximum for integers; random bytes for char arrays), pack
  it again and **recompute the CRC, and the signature where the link is keyed**, as an
  attacker who has the key (or a compromised peer) would. These reach the cores' handlers.

Everything is drawn from one ``random.Random``: a seed gives the same inputs.
"""

from __future__ import annotations

import functools
import hashlib
import math
import random
import struct
from collections.abc import Sequence

from ridsafe.common.codec import SigningConfig
from ridsafe.common.codec.wire import CRC_LEN, HEADER_LEN, SIGNATURE_LEN, layout, x25_crc

__all__ = ["ATTACKER_LINK_ID", "Mutator", "split_packets"]

ATTACKER_LINK_ID = 255

_FLOAT_EXTREMES = (math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 1e30, -1e30, 0.0, 1e-45)
_INT_RANGES = {
    "b": (-(2**7), 2**7 - 1),
    "B": (0, 2**8 - 1),
    "h": (-(2**15), 2**15 - 1),
    "H": (0, 2**16 - 1),
    "i": (-(2**31), 2**31 - 1),
    "I": (0, 2**32 - 1),
    "q": (-(2**63), 2**63 - 1),
    "Q": (0, 2**64 - 1),
}


def split_packets(data: bytes) -> list[bytes]:
    """The MAVLink 2 packets of a datagram, whole (header to signature), in order."""
    packets: list[bytes] = []
    i = 0
    while i + HEADER_LEN + CRC_LEN <= len(data):
        if data[i] != 0xFD:
            i += 1
            continue
        end = i + HEADER_LEN + data[i + 1] + CRC_LEN + (SIGNATURE_LEN if data[i + 2] & 1 else 0)
        if end > len(data):
            break
        packets.append(data[i:end])
        i = end
    return packets


@functools.lru_cache(maxsize=512)
def _formats(fmt: str) -> tuple[str, ...]:
    """One struct code per unpacked item of a message's format (``"<If3s"`` -> I f s);
    cached per format, as the campaign asks for the same few formats millions of times."""
    out: list[str] = []
    count = ""
    for char in fmt.lstrip("<>=!@"):
        if char.isdigit():
            count += char
            continue
        n = int(count) if count else 1
        out.extend([char] if char == "s" else [char] * n)
        count = ""
    return tuple(out)


class Mutator:
    """Seeded mutations of captured datagrams (see the module docstring)."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self._timestamp: int | None = None
        self._signing: SigningConfig | None = None
        self._packets: dict[bytes, list[bytes]] = {}  # a seed's packets, split once

    def mutate(self, seed: bytes, other: bytes, signing: SigningConfig | None = None) -> bytes:
        """One mutated datagram from ``seed`` (``other``: a second seed, for splicing);
        field mutations are signed with ``signing`` when the target link is keyed."""
        self._signing = signing
        if signing is not None and self._timestamp is None:
            # The mutator's own signing stream (link id 255), 100 s ahead of the genuine
            # ones' start: fresh to the receiver, the genuine streams' state left alone.
            self._timestamp = signing.initial_timestamp + 10**7
        if self.rng.random() < 0.5:
            packets = self._packets.get(seed)
            if packets is None:
                if len(self._packets) > 4096:  # a campaign's seeds are a few thousand
                    self._packets.clear()
                packets = self._packets.setdefault(seed, split_packets(seed))
            if packets:
                return self._mutate_fields(packets)
        return self._mutate_bytes(seed, other)

    # -- bytes ------------------------------------------------------------------------------

    def _mutate_bytes(self, seed: bytes, other: bytes) -> bytes:
        rng = self.rng
        data = bytearray(seed or b"\xfd")
        kind = rng.randrange(7)
        if kind == 0:
            for _ in range(rng.randint(1, 8)):
                data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        elif kind == 1:
            for _ in range(rng.randint(1, 8)):
                data[rng.randrange(len(data))] = rng.randrange(256)
        elif kind == 2:
            at = rng.randrange(len(data) + 1)
            data[at:at] = rng.randbytes(rng.randint(1, 32))
        elif kind == 3:
            del data[rng.randrange(len(data)) :]
        elif kind == 4:
            cut = rng.randrange(len(data) + 1)
            data = data[:cut] + other[rng.randrange(len(other) + 1) :]
        elif kind == 5:
            data = data * rng.randint(2, 4)
        else:
            data = bytearray(rng.randbytes(rng.randint(1, 300)))
        return bytes(data[:65_000])

    # -- fields -----------------------------------------------------------------------------

    def _mutate_fields(self, packets: Sequence[bytes]) -> bytes:
        rng = self.rng
        index = rng.randrange(len(packets))
        out = list(packets)
        out[index] = self._mutate_packet(packets[index])
        return b"".join(out)

    def _mutate_packet(self, packet: bytes) -> bytes:
        msg_id = packet[7] | packet[8] << 8 | packet[9] << 16
        packet_layout = layout(msg_id)
        if packet_layout is None:
            return packet
        unpacker = packet_layout.unpacker
        payload = packet[HEADER_LEN : HEADER_LEN + packet[1]].ljust(unpacker.size, b"\x00")
        values = list(unpacker.unpack(payload[: unpacker.size]))
        codes = _formats(unpacker.format)
        for _ in range(self.rng.randint(1, 3)):
            at = self.rng.randrange(len(values))
            values[at] = self._extreme(codes[at], values[at])
        data = unpacker.pack(*values)
        header = bytearray(packet[:HEADER_LEN])
        header[1] = len(data)
        header[2] = 0 if self._signing is None else 1
        body = bytes(header) + data
        body += x25_crc(body[1:] + packet_layout.crc_extra_byte).to_bytes(2, "little")
        return body if self._signing is None else self._sign(body, self._signing)

    def _extreme(self, code: str, value: object) -> object:
        rng = self.rng
        if code in "fd":
            return rng.choice(_FLOAT_EXTREMES)
        if code == "s":
            assert isinstance(value, bytes)
            return rng.randbytes(len(value))
        low, high = _INT_RANGES.get(code, (0, 255))
        return rng.choice((low, high, 0, rng.randint(low, high)))

    def _sign(self, body: bytes, signing: SigningConfig) -> bytes:
        """Sign as the key holder would, on the mutator's own stream."""
        timestamp = (self._timestamp or 0) + 1
        self._timestamp = timestamp
        body += struct.pack("<BQ", ATTACKER_LINK_ID, timestamp)[:7]
        return body + hashlib.sha256(signing.key + body).digest()[:6]
