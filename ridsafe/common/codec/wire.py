"""MAVLink 2 framing mechanics: the CRC, the header, a payload's bytes and a payload's view.

pymavlink's parser works a byte at a time and builds a message object per packet; on the hot
path (a 16-aircraft lockstep run moves ~200k messages) that cost 3x what this does: find
packets with bytes.find, check the CRC with binascii, unpack the payload with the message's
own struct and hand the fields to the domain conversion as attributes (``Layout.view``).
A uint8 array travels as one bytes item, not one Python int per byte (``registry.wire_struct``,
``BYTES_VIEW_MESSAGES``): the same bytes on the wire.

Packet (MAVLink 2): ``STX(0xFD) len incompat compat seq sysid compid msgid(3) payload
crc(2) [signature(13)]``; the CRC (X.25) covers everything after STX plus the message's CRC
extra byte. Nothing here keeps state between calls: the per-link state (sequence numbers,
the parse buffer, signing) is ``link.MavlinkLink``'s.
"""

from __future__ import annotations

import binascii
import collections
import functools
import math
import operator
import struct
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any, NamedTuple, cast

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common.codec.registry import (
    byte_arrays,
    decoder_for,
    rows_decoder_for,
    to_wire,
    wire_struct,
    wire_values,
)
from ridsafe.common.codec.ridsafe_messages import observation_rows_payloads
from ridsafe.common.codec.units import FromMav
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError

STX_V1 = 0xFE
STX_V2 = 0xFD
HEADER_LEN = 10
CRC_LEN = 2
SIGNATURE_LEN = 13
IFLAG_SIGNED = mav.MAVLINK_IFLAG_SIGNED
HEADER = struct.Struct("<BBBBBBBHB")
_BIT_REVERSED = bytes(int(f"{i:08b}"[::-1], 2) for i in range(256))
_CRC_EXTRA_BYTE = tuple(bytes([extra]) for extra in range(256))


def x25_crc(data: bytes) -> int:
    """MAVLink's CRC-16/MCRF4XX (X.25): the reflected form of CRC-CCITT, computed with
    binascii.crc_hqx on bit-reversed bytes and bit-reversed back."""
    crc = binascii.crc_hqx(data.translate(_BIT_REVERSED), 0xFFFF)
    return _BIT_REVERSED[crc & 0xFF] << 8 | _BIT_REVERSED[crc >> 8]


class Payload(NamedTuple):
    """One message's payload as it goes on the wire, ready to be framed by any link."""

    msg_id: int
    crc_extra_byte: bytes
    data: bytes  # MAVLink 2 trims trailing zeros but keeps at least one byte


def encode_payload(message: m.Message) -> Payload:
    """The payload of a domain message (raises WireError if it cannot be encoded). Encoding
    once and framing per link (``MavlinkLink.frame``) sends one message to many peers."""
    if type(message) is m.RidFrameReport:
        return _rid_frame_payload(message)
    return _encoded(message)


_PACK = mav.MAVLink_ridsafe_observation_pack_message


def encode_payloads(messages: Sequence[m.Message]) -> list[Payload]:
    """``encode_payload`` of each message, in order (raises WireError as it does); a batch of
    reports (``ObservationRows``, a companion's second of them) as its
    RIDSAFE_OBSERVATION_PACKs, three reports to a pack, encoded in one compiled pass
    (``ridsafe_messages.observation_rows_payloads``) to the bytes each pack of
    ``ridsafe_messages.pack_rows`` would have."""
    payloads: list[Payload] = []
    for message in messages:
        if type(message) is not m.ObservationRows:
            payloads.append(encode_payload(message))
            continue
        datas = observation_rows_payloads(message)
        if datas is None:
            raise WireError("a report of the batch does not fit RIDSAFE_OBSERVATION_PACK")
        crc_extra = _CRC_EXTRA_BYTE[_PACK.crc_extra]
        payloads += [Payload(_PACK.id, crc_extra, data) for data in datas]
    return payloads


def _encoded(message: m.Message) -> Payload:
    wire = to_wire(message)
    data = wire_struct(wire.cls).pack(*wire_values(wire))
    return Payload(
        wire.cls.id, _CRC_EXTRA_BYTE[wire.cls.crc_extra], data.rstrip(b"\x00") or data[:1]
    )


#: RIDSAFE_RID_FRAME's first field on the wire (the largest type first): the signal strength.
_RSSI_F32 = struct.Struct("<f")
#: (frame, sender id, transport, channel) -> (message id, CRC extra, the payload after the
#: signal strength) of frames encoded lately. One frame is heard by every aircraft in range,
#: and their reports differ only in the signal strength: at 16 aircraft each frame the sim's
#: radio carries is reported by about 15 receivers (41,000 reports a run).
_RID_FRAME_TAILS: dict[tuple[bytes, bytes, int, int], tuple[int, bytes, bytes]] = {}
_RID_FRAME_TAILS_SIZE = 256


def _rid_frame_payload(report: m.RidFrameReport) -> Payload:
    """``_encoded(report)``, its bytes after the signal strength remembered per frame."""
    key = (report.frame, report.sender_id, report.transport, report.channel)
    tail = _RID_FRAME_TAILS.get(key)
    if tail is not None:
        msg_id, crc_extra, rest = tail
        return Payload(msg_id, crc_extra, _RSSI_F32.pack(report.rssi_dbm) + rest)
    payload = _encoded(report)
    if len(payload.data) > _RSSI_F32.size:  # else the rest was all zeros, trimmed away
        if len(_RID_FRAME_TAILS) >= _RID_FRAME_TAILS_SIZE:
            _RID_FRAME_TAILS.clear()
        rest = payload.data[_RSSI_F32.size :]
        _RID_FRAME_TAILS[key] = (payload.msg_id, payload.crc_extra_byte, rest)
    return payload


@dataclass(frozen=True)
class RidFrameTails:
    """Frames' RIDSAFE_RID_FRAME payloads after the signal strength, joined: what every
    receiver's report of one frame shares (``MavlinkLink.frame_rid_reports`` frames many
    reports of them at once). Tail k is ``joined[start[k] : start[k] + length[k]]``."""

    joined: NDArray[np.uint8]
    start: NDArray[np.int64]
    length: NDArray[np.int64]

    @classmethod
    def of(cls, reports: Sequence[m.RidFrameReport]) -> RidFrameTails:
        """The tails of the reports' frames (their signal strengths aside); raises WireError
        for a report that cannot be encoded."""
        # At a strength of 1.0 (last byte 0x3f) none of the tail's leading bytes is trimmed.
        tails = [
            _rid_frame_payload(replace(r, rssi_dbm=1.0)).data[_RSSI_F32.size :] for r in reports
        ]
        length = np.array([len(tail) for tail in tails], dtype=np.int64)
        start = np.concatenate(([0], np.cumsum(length)[:-1])).astype(np.int64)
        return cls(np.frombuffer(b"".join(tails), np.uint8), start, length)


#: The decoding twin of ``_RID_FRAME_TAILS``: a RIDSAFE_RID_FRAME payload's bytes after the
#: signal strength -> the report decoded from them lately. A receiver's link decodes only the
#: strength of a frame another receiver's link (a core of this process) decoded whole.
_RID_FRAME_REPORTS: dict[bytes, m.RidFrameReport] = {}


def known_rid_frame(payload: bytes) -> m.RidFrameReport | None:
    """The report of a RIDSAFE_RID_FRAME payload whose bytes after the signal strength were
    decoded lately (``remember_rid_frame``), with this payload's strength; None when they
    were not, or the strength is not finite (the whole decoding then says why)."""
    if len(payload) <= _RSSI_F32.size:
        return None
    known = _RID_FRAME_REPORTS.get(payload[_RSSI_F32.size :])
    if known is None:
        return None
    (rssi_dbm,) = _RSSI_F32.unpack_from(payload)
    if not math.isfinite(rssi_dbm):
        return None
    return m.RidFrameReport(known.frame, rssi_dbm, known.sender_id, known.transport, known.channel)


def known_rid_frames(payloads: Sequence[bytes]) -> m.RidFrameReports | None:
    """RIDSAFE_RID_FRAME payloads decoded together (``MavlinkLink``'s columnar decoding),
    each what ``known_rid_frame`` makes of it; None when one is not known or not finite: the
    caller then decodes them one by one, which decodes that one whole (and remembers it) or
    says why not."""
    reports = [known_rid_frame(payload) for payload in payloads]
    if any(report is None for report in reports):
        return None
    return m.RidFrameReports(tuple(cast("list[m.RidFrameReport]", reports)))


def remember_rid_frame(payload: bytes, report: m.Message) -> None:
    """Keep a valid report decoded from ``payload`` whole, for ``known_rid_frame``."""
    if len(payload) > _RSSI_F32.size and type(report) is m.RidFrameReport:
        if len(_RID_FRAME_REPORTS) >= _RID_FRAME_TAILS_SIZE:
            _RID_FRAME_REPORTS.clear()
        _RID_FRAME_REPORTS[payload[_RSSI_F32.size :]] = report


def _view_type(name: str, fieldnames: tuple[str, ...]) -> Callable[[Iterable[Any]], Any]:
    """The maker of a decoded packet's view: a named tuple of the fields in XML order, read
    as attributes by the from-MAVLink functions, with pymavlink's ``get_type`` and
    ``get_fieldnames`` (a tuple is built in one C call, where an object with a ``__dict__``
    took one store per field)."""
    fields = collections.namedtuple(f"{name}_view", fieldnames)  # type: ignore[misc]
    view: Any = type(
        fields.__name__,
        (fields,),
        {
            "__slots__": (),
            "get_type": lambda self: name,
            "get_fieldnames": lambda self: fieldnames,
        },
    )
    return view._make  # type: ignore[no-any-return]


@dataclass(frozen=True)
class Layout:
    """How to unpack one message id: its struct, CRC extra and fields in XML order."""

    name: str
    crc_extra_byte: bytes
    unpacker: struct.Struct
    slices: tuple[tuple[int, int], ...]  # per field: (index in the unpacked tuple, length)
    # The first unpacked item of every field, in XML order, in one C call; then the few
    # fields that are more than that: arrays (field index, tip, length) and char arrays.
    firsts: Callable[[tuple[Any, ...]], Any]
    arrays: tuple[tuple[int, int, int], ...]
    chars: tuple[int, ...]
    make_view: Callable[[Iterable[Any]], Any]
    decode: FromMav | None  # the domain message of a view; None: the apps do not use it
    #: Many payloads of this message at once (``MavlinkLink``'s columnar decoding), or None
    #: when one of them is not plainly valid; None: no columnar decoding.
    decode_rows: Callable[[Sequence[bytes]], m.ObservationRows | m.RidFrameReports | None] | None
    #: The message of a payload from what a payload alike but for its first bytes decoded
    #: to (None: not known), and what keeps a decoding for it (``known_rid_frame``).
    decode_known: Callable[[bytes], m.Message | None] | None
    remember: Callable[[bytes, m.Message], None] | None
    remembered: bool  # its decodings kept by the links' memo (not in UNIQUE_PAYLOAD_MESSAGES)

    def view(self, payload: bytes) -> Any:
        """The fields of ``payload`` (trailing zeros restored) as attributes."""
        if len(payload) < self.unpacker.size:  # MAVLink 2 trims trailing zero bytes
            payload = payload + bytes(self.unpacker.size - len(payload))
        t = self.unpacker.unpack(payload[: self.unpacker.size])
        firsts = self.firsts(t)
        if len(self.slices) == 1:
            firsts = (firsts,)
        if not (self.arrays or self.chars):
            return self.make_view(firsts)
        values = list(firsts)
        for index, tip, length in self.arrays:
            values[index] = t[tip : tip + length]
        for index in self.chars:
            values[index] = values[index].rstrip(b"\x00")
        return self.make_view(values)


#: Messages whose decoded view holds each uint8 array as bytes (unpacked as one ``Ns`` item,
#: ``registry.wire_struct``) rather than a tuple of ints: their from-MAVLink functions read
#: those fields with ``bytes(...)`` / slices, which give the same result for either. A RID
#: frame report is 250 such bytes, and every aircraft hears ~20 per second.
BYTES_VIEW_MESSAGES = frozenset({"RIDSAFE_RID_FRAME", "RIDSAFE_OBSERVATION_PACK"})

#: Messages whose payload is, by what it carries, almost never received twice: a measurement
#: with its own time or a per-receiver signal strength (``link.DECODED_MEMO_SIZE``'s memo
#: would only hash, keep and drop them: at 16 aircraft 100,000 a run, 20 of them met again).
UNIQUE_PAYLOAD_MESSAGES = frozenset(
    {
        "RIDSAFE_RID_FRAME",  # the RSSI of one receiver
        "RIDSAFE_OBSERVATION",  # one receiver's report with its receive time
        "RIDSAFE_OBSERVATION_PACK",  # three of them
        "GLOBAL_POSITION_INT",  # time_boot_ms and the position of one vehicle
        "LOCAL_POSITION_NED",
        "ATTITUDE",
        "OPEN_DRONE_ID_LOCATION",  # its own timestamp
        "SET_POSITION_TARGET_LOCAL_NED",  # time_boot_ms
    }
)


#: Messages decoded through a memo of their payload after a per-receiver head.
_TAIL_MEMOS: dict[
    str, tuple[Callable[[bytes], m.Message | None], Callable[[bytes, m.Message], None]]
] = {"RIDSAFE_RID_FRAME": (known_rid_frame, remember_rid_frame)}
#: Their columnar decoding through that memo (a companion hears 63 frames in one datagram
#: at 64 aircraft, all but the first receiver's already decoded in this process).
_TAIL_RUNS: dict[str, Callable[[Sequence[bytes]], m.RidFrameReports | None]] = {
    "RIDSAFE_RID_FRAME": known_rid_frames
}


@functools.cache
def layout(msg_id: int) -> Layout | None:
    """How to check and unpack message id ``msg_id`` (None: not in the dialect)."""
    cls = mav.mavlink_map.get(msg_id)
    if cls is None:
        return None
    chars = _char_fields(cls)
    unpacker, lengths = cls.unpacker, list(cls.lengths)
    if cls.msgname in BYTES_VIEW_MESSAGES:
        unpacker = wire_struct(cls)
        lengths = [1 if w in byte_arrays(cls) else n for w, n in enumerate(lengths)]
    tips = [sum(lengths[:order]) for order in cls.orders]
    slices = tuple((tip, lengths[order]) for tip, order in zip(tips, cls.orders, strict=True))
    known, remember = _TAIL_MEMOS.get(cls.msgname, (None, None))
    return Layout(
        cls.msgname,
        _CRC_EXTRA_BYTE[cls.crc_extra],
        unpacker,
        slices,
        operator.itemgetter(*(tip for tip, _ in slices)),
        tuple((i, tip, length) for i, (tip, length) in enumerate(slices) if length > 1),
        chars,
        _view_type(cls.msgname, tuple(cls.fieldnames)),
        decoder_for(cls.msgname),
        rows_decoder_for(cls.msgname) or _TAIL_RUNS.get(cls.msgname),
        known,
        remember,
        cls.msgname not in UNIQUE_PAYLOAD_MESSAGES,
    )


def _char_fields(cls: Any) -> tuple[int, ...]:
    """XML indices of the fields ``cls.unpacker`` unpacks as bytes (char and char arrays)."""
    lengths = cls.lengths
    tips = [sum(lengths[:order]) for order in cls.orders]
    firsts = cls.unpacker.unpack(bytes(cls.unpacker.size))
    return tuple(i for i, tip in enumerate(tips) if isinstance(firsts[tip], bytes))
