"""The radiotap header in front of a monitor-mode 802.11 frame: signal strength and channel.

Layout (radiotap.org): version u8 (0), pad u8, length u16 LE (the whole header), then one or
more u32 LE present bitmasks (bit 31: another bitmask follows), then the fields of every set
bit in bit order, bitmask after bitmask, each aligned to its own natural alignment counted from
the start of the header. Bits 29, 30 and 31 of every bitmask are special: 29 returns the
*next* bitmask to the radiotap namespace, 30 moves it to a vendor namespace (a 6-byte field,
aligned to 2: OUI[3], sub-namespace u8, skip_length u16; the vendor's fields are then
``skip_length`` bytes, skipped whole), 31 says another bitmask follows. Bit 28 (TLV) means
the rest of the header is a list of TLVs (type u16, length u16, value padded to 4) and no
bitmask field follows it.

Read here: bit 1 Flags (0x10: the frame ends with a 4-byte FCS), bit 3 Channel (frequency
MHz), bit 5 dBm antenna signal (int8). The first antenna signal of the radiotap namespace is
the combined one and is what is reported; a TLV of type 5 is read the same way when no
bitmask field gave one.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

__all__ = ["RadiotapError", "RadiotapInfo", "channel_number", "parse_radiotap"]


class RadiotapError(ValueError):
    """The radiotap header does not parse (its message says where and why)."""


@dataclass(frozen=True, slots=True)
class RadiotapInfo:
    """What the header says about the frame after it (``header_len`` bytes in)."""

    header_len: int
    antenna_signal_dbm: int | None
    frequency_mhz: int | None
    has_fcs: bool


#: (alignment, size) of the radiotap namespace's fields by bit, as radiotap.org defines them.
FIELDS: dict[int, tuple[int, int]] = {
    0: (8, 8),  # TSFT
    1: (1, 1),  # Flags
    2: (1, 1),  # Rate
    3: (2, 4),  # Channel: frequency u16, flags u16
    4: (1, 2),  # FHSS
    5: (1, 1),  # dBm antenna signal
    6: (1, 1),  # dBm antenna noise
    7: (2, 2),  # lock quality
    8: (2, 2),  # TX attenuation
    9: (2, 2),  # dB TX attenuation
    10: (1, 1),  # dBm TX power
    11: (1, 1),  # antenna
    12: (1, 1),  # dB antenna signal
    13: (1, 1),  # dB antenna noise
    14: (2, 2),  # RX flags
    15: (2, 2),  # TX flags
    16: (1, 1),  # RTS retries
    17: (1, 1),  # data retries
    18: (4, 8),  # XChannel
    19: (1, 3),  # MCS
    20: (4, 8),  # A-MPDU status
    21: (2, 12),  # VHT
    22: (8, 12),  # timestamp
    23: (2, 12),  # HE
    24: (2, 12),  # HE-MU
    25: (2, 6),  # HE-MU-other-user
    26: (1, 1),  # 0-length PSDU
    27: (2, 4),  # L-SIG
}
BIT_FLAGS, BIT_CHANNEL, BIT_ANTENNA_SIGNAL = 1, 3, 5
BIT_TLV, BIT_RADIOTAP_NS, BIT_VENDOR_NS, BIT_EXT = 28, 29, 30, 31
FLAG_FCS = 0x10
VENDOR_NS_FIELD = (2, 6)
TLV_ANTENNA_SIGNAL = 5


def _bitmasks(data: bytes, header_len: int) -> tuple[list[int], int]:
    """The present bitmasks and the offset of the first field."""
    masks: list[int] = []
    position = 4
    while True:
        if position + 4 > header_len:
            raise RadiotapError(f"present bitmask {len(masks)} runs past the header's end")
        mask = struct.unpack_from("<I", data, position)[0]
        masks.append(mask)
        position += 4
        if not mask & (1 << BIT_EXT):
            return masks, position


class _Walk:
    """Field offsets in header order (alignment from the header's start)."""

    def __init__(self, header_len: int, position: int) -> None:
        self.end, self.position = header_len, position

    def take(self, align: int, size: int, what: str) -> int:
        start = self.position + (-self.position % align)
        if start + size > self.end:
            raise RadiotapError(f"{what} at byte {start} runs past the header ({self.end} bytes)")
        self.position = start + size
        return start


def parse_radiotap(data: bytes) -> RadiotapInfo:
    if len(data) < 8:
        raise RadiotapError(f"radiotap header needs 8 bytes, packet has {len(data)}")
    version, _pad, header_len = struct.unpack_from("<BBH", data)
    if version != 0:
        raise RadiotapError(f"radiotap version 0 expected, got {version}")
    if not 8 <= header_len <= len(data):
        raise RadiotapError(f"radiotap length {header_len} in a {len(data)}-byte packet")
    masks, first_field = _bitmasks(data, header_len)
    walk = _Walk(header_len, first_field)
    found: dict[int, int] = {}  # bit -> offset, radiotap namespace, first occurrence
    in_radiotap, tlvs, vendor_skip = True, False, 0
    for mask in masks:
        if in_radiotap:
            tlvs = _radiotap_fields(walk, mask, found)
            if tlvs:
                break
        else:  # a vendor namespace: its fields are skip_length bytes, whatever the bits
            walk.take(1, vendor_skip, "vendor namespace data")
            vendor_skip = 0
        if mask & (1 << BIT_VENDOR_NS):
            vendor_at = walk.take(*VENDOR_NS_FIELD, "vendor namespace")
            vendor_skip = struct.unpack_from("<H", data, vendor_at + 4)[0]
            in_radiotap = False
        elif mask & (1 << BIT_RADIOTAP_NS):
            in_radiotap = True
    signal = _field_signal(data, found)
    if signal is None and tlvs:
        signal = _tlv_signal(data, walk.position, header_len)
    frequency = None
    if BIT_CHANNEL in found:
        frequency = struct.unpack_from("<H", data, found[BIT_CHANNEL])[0]
    has_fcs = BIT_FLAGS in found and bool(data[found[BIT_FLAGS]] & FLAG_FCS)
    return RadiotapInfo(header_len, signal, frequency, has_fcs)


def _radiotap_fields(walk: _Walk, mask: int, found: dict[int, int]) -> bool:
    """Step over the fields of one radiotap-namespace bitmask, noting where each is; True
    if it announces TLVs (the rest of the header)."""
    for bit in range(BIT_RADIOTAP_NS):
        if not mask & (1 << bit):
            continue
        if bit == BIT_TLV:
            return True
        if bit not in FIELDS:
            raise RadiotapError(f"field bit {bit} has no known size: cannot read past it")
        found.setdefault(bit, walk.take(*FIELDS[bit], f"field {bit}"))
    return False


def _field_signal(data: bytes, found: dict[int, int]) -> int | None:
    if BIT_ANTENNA_SIGNAL not in found:
        return None
    value: int = struct.unpack_from("<b", data, found[BIT_ANTENNA_SIGNAL])[0]
    return value


def _tlv_signal(data: bytes, position: int, header_len: int) -> int | None:
    position += -position % 4
    while position + 4 <= header_len:
        kind, length = struct.unpack_from("<HH", data, position)
        value_at = position + 4
        if value_at + length > header_len:
            raise RadiotapError(f"TLV {kind} at byte {position} runs past the header")
        if kind == TLV_ANTENNA_SIGNAL and length >= 1:
            signal: int = struct.unpack_from("<b", data, value_at)[0]
            return signal
        position = value_at + length + (-length % 4)
    return None


def channel_number(frequency_mhz: int) -> int:
    """IEEE 802.11 channel number of a centre frequency (0 if none fits)."""
    if frequency_mhz == 2484:
        return 14
    if 2412 <= frequency_mhz <= 2472:
        return (frequency_mhz - 2407) // 5
    if 5955 <= frequency_mhz <= 7115:
        return (frequency_mhz - 5950) // 5
    if 5000 <= frequency_mhz <= 5900:
        return (frequency_mhz - 5000) // 5
    return 0
