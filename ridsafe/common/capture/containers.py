"""Capture files -> their packet records: pcap, pcapng and btsnoop, told apart by magic.

Pure: bytes in, records out. Each record keeps where it came from (record number from 1,
byte offset of its header in the file) so that every later complaint can name it.

========  ==================================================================================
format    layout (what is read; everything else is skipped)
========  ==================================================================================
pcap      24-byte header: magic a1b2c3d4 (us) or a1b23c4d (ns), either byte order; link type
          at byte 20. Records: ts_sec, ts_frac, incl_len, orig_len (u32 each), then incl_len
          bytes.
pcapng    blocks of (type u32, total length u32, body, total length u32), padded to 4 bytes;
          the byte order is the Section Header Block's (type 0a0d0d0a, magic 1a2b3c4d).
          Interface Description (type 1): link type u16, if_tsresol (option 9, default 1e-6
          s) and if_tsoffset (option 14, s). Enhanced Packet (type 6): interface u32,
          timestamp high/low u32, captured length, original length, data. Obsolete Packet
          (type 2): interface u16, drops u16, then as Enhanced. Other blocks are skipped.
btsnoop   16-byte header "btsnoop\\0", version u32 = 1, datalink u32 (1001 HCI without
          packet type, 1002 HCI UART H4, 2001 Linux monitor as ``btmon -w`` writes);
          big-endian records: original length, included length, flags, drops (u32 each),
          timestamp (i64, us since year 0 AD), then the packet.
========  ==================================================================================

A record cut short at the end of the file is reported as a problem and ends the file; a
header that cannot be read at all raises :class:`CaptureError` naming the file and offset.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Iterator
from dataclasses import dataclass

from ridsafe.common.errors import RidsafeError

__all__ = [
    "BTSNOOP_EPOCH_OFFSET_US",
    "CaptureError",
    "CaptureFormat",
    "LinkType",
    "RawRecord",
    "RecordProblem",
    "detect_format",
    "read_records",
]


class CaptureError(RidsafeError, ValueError):
    """A capture file cannot be read (not a capture, or a header that makes no sense)."""

    def __init__(self, source: str, offset: int, reason: str) -> None:
        super().__init__(f"{source}: byte {offset}: {reason}")
        self.source = source
        self.offset = offset
        self.reason = reason


class CaptureFormat(enum.Enum):
    PCAP = "pcap"
    PCAPNG = "pcapng"
    BTSNOOP = "btsnoop"


class LinkType(enum.IntEnum):
    """Link types the decoder reads (pcap LINKTYPE_* numbers; btsnoop's mapped onto them)."""

    IEEE802_11_RADIOTAP = 127
    BLUETOOTH_HCI_H4 = 187
    BLUETOOTH_HCI_H4_WITH_PHDR = 201
    BLUETOOTH_LINUX_MONITOR = 254
    #: btsnoop datalink 1001: an HCI packet without its H4 type byte; the flags say which.
    BTSNOOP_HCI_UNENCAPSULATED = 1001
    #: btsnoop datalink 2001 (``btmon -w``): the flags hold (adapter << 16) | opcode.
    BTSNOOP_LINUX_MONITOR = 2001


@dataclass(frozen=True, slots=True)
class RawRecord:
    """One packet: its number (from 1) and byte offset in the file, capture time in ns since
    the Unix epoch, link type, and for btsnoop the record's flags."""

    number: int
    offset: int
    t_unix_ns: int
    link_type: int
    data: bytes
    flags: int = 0


@dataclass(frozen=True, slots=True)
class RecordProblem:
    """A record that could not be read (counted under ``reason``; ``detail`` for people)."""

    number: int
    offset: int
    reason: str
    detail: str


#: Microseconds from 0000-01-01 (btsnoop's epoch) to 1970-01-01.
BTSNOOP_EPOCH_OFFSET_US = 0x00DCDDB30F2F8000

_PCAP_MAGIC_US = 0xA1B2C3D4
_PCAP_MAGIC_NS = 0xA1B23C4D
_PCAPNG_SHB = 0x0A0D0D0A
_PCAPNG_BYTE_ORDER = 0x1A2B3C4D
_BTSNOOP_MAGIC = b"btsnoop\x00"
_BTSNOOP_LINKS = {
    1001: LinkType.BTSNOOP_HCI_UNENCAPSULATED,
    1002: LinkType.BLUETOOTH_HCI_H4,
    2001: LinkType.BTSNOOP_LINUX_MONITOR,
}
#: A record longer than this is hostile (no link type here carries more).
MAX_RECORD_BYTES = 1 << 18

Item = RawRecord | RecordProblem


def detect_format(data: bytes, source: str) -> CaptureFormat:
    if data[:8] == _BTSNOOP_MAGIC:
        return CaptureFormat.BTSNOOP
    if len(data) >= 4:
        magic_le, magic_be = struct.unpack_from("<I", data)[0], struct.unpack_from(">I", data)[0]
        if magic_le == _PCAPNG_SHB:
            return CaptureFormat.PCAPNG
        if {magic_le, magic_be} & {_PCAP_MAGIC_US, _PCAP_MAGIC_NS}:
            return CaptureFormat.PCAP
    raise CaptureError(
        source, 0, f"not a pcap, pcapng or btsnoop file (starts {data[:8].hex() or 'empty'})"
    )


def read_records(data: bytes, source: str) -> Iterator[Item]:
    """Every record of the capture in file order, or the problem that stopped one."""
    readers = {
        CaptureFormat.PCAP: _pcap,
        CaptureFormat.PCAPNG: _pcapng,
        CaptureFormat.BTSNOOP: _btsnoop,
    }
    return readers[detect_format(data, source)](data, source)


def _truncated(number: int, offset: int, what: str, need: int, have: int) -> RecordProblem:
    return RecordProblem(
        number, offset, "truncated", f"{what} needs {need} bytes, the file has {have} left"
    )


def _pcap(data: bytes, source: str) -> Iterator[Item]:
    if len(data) < 24:
        raise CaptureError(source, 0, f"pcap header needs 24 bytes, file has {len(data)}")
    order = "<" if struct.unpack_from("<I", data)[0] in (_PCAP_MAGIC_US, _PCAP_MAGIC_NS) else ">"
    magic, _major, _minor, _zone, _sigfigs, _snaplen, link = struct.unpack_from(
        order + "IHHiIII", data
    )
    frac_ns = 1 if magic == _PCAP_MAGIC_NS else 1000
    record = struct.Struct(order + "IIII")
    offset, number = 24, 0
    while offset < len(data):
        number += 1
        if len(data) - offset < record.size:
            yield _truncated(number, offset, "record header", record.size, len(data) - offset)
            return
        ts_s, ts_frac, incl_len, _orig = record.unpack_from(data, offset)
        body = offset + record.size
        if incl_len > MAX_RECORD_BYTES:
            yield RecordProblem(number, offset, "hostile", f"record claims {incl_len} bytes")
            return
        if len(data) - body < incl_len:
            yield _truncated(number, offset, "record", incl_len, len(data) - body)
            return
        t_ns = ts_s * 1_000_000_000 + ts_frac * frac_ns
        yield RawRecord(number, offset, t_ns, link, data[body : body + incl_len])
        offset = body + incl_len


@dataclass
class _Interface:
    link_type: int
    ticks_per_s: int = 1_000_000
    offset_s: int = 0


def _tsresol(value: int) -> int:
    exponent = value & 0x7F
    return 1 << exponent if value & 0x80 else int(10**exponent)


def _pcapng_options(body: bytes, start: int, order: str) -> Iterator[tuple[int, bytes]]:
    """(code, value) of the options from ``start`` until opt_endofopt or the body's end."""
    position = start
    while position + 4 <= len(body):
        code, length = struct.unpack_from(order + "HH", body, position)
        if code == 0:
            return
        value = body[position + 4 : position + 4 + length]
        if len(value) < length:
            return
        yield code, value
        position += 4 + length + (-length % 4)


def _interface(body: bytes, order: str) -> _Interface:
    iface = _Interface(struct.unpack_from(order + "H", body)[0])
    for code, value in _pcapng_options(body, 8, order):
        if code == 9 and len(value) >= 1:
            iface.ticks_per_s = _tsresol(value[0])
        elif code == 14 and len(value) >= 8:
            iface.offset_s = int(struct.unpack_from(order + "q", value)[0])
    return iface


def _pcapng(data: bytes, source: str) -> Iterator[Item]:
    order = "<"
    interfaces: list[_Interface] = []
    offset, number = 0, 0
    while offset < len(data):
        if len(data) - offset < 12:
            yield _truncated(number + 1, offset, "block header", 12, len(data) - offset)
            return
        block_type = struct.unpack_from(order + "I", data, offset)[0]
        if block_type == _PCAPNG_SHB:
            order = _section_order(data, offset, source)
            interfaces = []
        length = struct.unpack_from(order + "I", data, offset + 4)[0]
        if length < 12 or length % 4 or length > MAX_RECORD_BYTES:
            if block_type == _PCAPNG_SHB:
                raise CaptureError(source, offset, f"section header block length {length}")
            yield RecordProblem(number + 1, offset, "hostile", f"block length {length}")
            return
        if len(data) - offset < length:
            yield _truncated(number + 1, offset, "block", length, len(data) - offset)
            return
        body = data[offset + 8 : offset + length - 4]
        if block_type == 1 and len(body) >= 8:
            interfaces.append(_interface(body, order))
        elif block_type in (2, 6):
            number += 1
            yield _packet_block(block_type, body, order, interfaces, number, offset)
        offset += length


def _section_order(data: bytes, offset: int, source: str) -> str:
    if len(data) - offset < 12:
        raise CaptureError(source, offset, "section header block cut short")
    for order in ("<", ">"):
        if struct.unpack_from(order + "I", data, offset + 8)[0] == _PCAPNG_BYTE_ORDER:
            return order
    magic = data[offset + 8 : offset + 12].hex()
    raise CaptureError(source, offset + 8, f"byte-order magic 1a2b3c4d expected, got {magic}")


def _packet_block(
    block_type: int,
    body: bytes,
    order: str,
    interfaces: list[_Interface],
    number: int,
    offset: int,
) -> Item:
    if len(body) < 20:
        return RecordProblem(number, offset, "truncated", f"packet block body {len(body)} bytes")
    if block_type == 6:
        iface_id, high, low, caplen, _orig = struct.unpack_from(order + "IIIII", body)
    else:
        iface_id, _drops, high, low, caplen, _orig = struct.unpack_from(order + "HHIIII", body)
    if iface_id >= len(interfaces):
        return RecordProblem(number, offset, "no_interface", f"interface {iface_id} undefined")
    if caplen > len(body) - 20:
        return RecordProblem(
            number, offset, "truncated", f"packet of {caplen} bytes in a {len(body)}-byte body"
        )
    iface = interfaces[iface_id]
    ticks = (high << 32) | low
    t_ns = ticks * 1_000_000_000 // iface.ticks_per_s + iface.offset_s * 1_000_000_000
    return RawRecord(number, offset, t_ns, iface.link_type, body[20 : 20 + caplen])


def _btsnoop(data: bytes, source: str) -> Iterator[Item]:
    if len(data) < 16:
        raise CaptureError(source, 0, f"btsnoop header needs 16 bytes, file has {len(data)}")
    version, datalink = struct.unpack_from(">II", data, 8)
    if version != 1:
        raise CaptureError(source, 8, f"btsnoop version 1 expected, got {version}")
    if datalink not in _BTSNOOP_LINKS:
        known = ", ".join(str(k) for k in _BTSNOOP_LINKS)
        raise CaptureError(source, 12, f"btsnoop datalink {datalink} not read (read: {known})")
    link = int(_BTSNOOP_LINKS[datalink])
    record = struct.Struct(">IIIIq")
    offset, number = 16, 0
    while offset < len(data):
        number += 1
        if len(data) - offset < record.size:
            yield _truncated(number, offset, "record header", record.size, len(data) - offset)
            return
        _orig, incl_len, flags, _drops, t_us = record.unpack_from(data, offset)
        body = offset + record.size
        if incl_len > MAX_RECORD_BYTES:
            yield RecordProblem(number, offset, "hostile", f"record claims {incl_len} bytes")
            return
        if len(data) - body < incl_len:
            yield _truncated(number, offset, "record", incl_len, len(data) - body)
            return
        t_ns = (t_us - BTSNOOP_EPOCH_OFFSET_US) * 1000
        yield RawRecord(number, offset, t_ns, link, data[body : body + incl_len], flags)
        offset = body + incl_len
