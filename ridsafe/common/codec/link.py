"""One end of one MAVLink 2 link, sans I/O: ``pack(message) -> bytes``, ``feed(bytes) ->
list[Received]``.

All the codec state of a link lives in its ``MavlinkLink``: the outgoing sequence number,
the parse buffer of a byte stream, the signing clock and replay window, the counters. Two
links (two cores in one process) share no state; they share only a bounded memo of the pure
payload -> message decoding (``DECODED_MEMO_SIZE``). A link never raises on input: malformed
frames, unknown message ids, values out of range and unsigned or wrongly signed packets are
logged, counted in ``LinkCounters`` and dropped, and parsing goes on with the next frame.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import messages as m
from ridsafe.common.codec.frame_kernels import (
    CRC_BYTES,
    HEAD_BYTES,
    HEADER_BYTES,
    NOT_PLAIN,
    frame_headed,
    scan_packets,
)
from ridsafe.common.codec.inbound import first_invalid_field, rows_valid
from ridsafe.common.codec.signing import ReplayWindow, SigningConfig, SigningState
from ridsafe.common.codec.wire import (
    CRC_LEN,
    HEADER,
    HEADER_LEN,
    IFLAG_SIGNED,
    SIGNATURE_LEN,
    STX_V1,
    STX_V2,
    Layout,
    Payload,
    RidFrameTails,
    encode_payload,
    encode_payloads,
    layout,
    x25_crc,
)
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError
from ridsafe.common.frozen import quick_init

logger = logging.getLogger(__name__)

#: Decoding is a pure function of (message layout, payload bytes) and domain messages are
#: immutable, so a payload decoded once is not decoded again while it is remembered: the
#: GCS's regions, alerts and heartbeats reach every companion with the same payload (only
#: the header and signature differ), and so do the many constant heartbeats. Only valid
#: messages are remembered (a rejected payload is rejected, counted and logged each time),
#: and only of the messages that can repeat (not ``wire.UNIQUE_PAYLOAD_MESSAGES``); the memo
#: is cleared when full. Shared by every link of the process.
DECODED_MEMO_SIZE = 4096
_DECODED: dict[tuple[str, bytes], m.Message] = {}
_RID_FRAME = mav.MAVLink_ridsafe_rid_frame_message
#: A RIDSAFE_RID_FRAME packet's bytes besides its frame's tail (unsigned).
_RID_PACKET_OVERHEAD = HEADER_BYTES + HEAD_BYTES + CRC_BYTES
#: The largest finite float32: a larger strength would not pack (``struct`` raises).
_F32_MAX = float(np.finfo(np.float32).max)
#: Unsigned (incompatibility flags 0), its message id, its CRC extra.
_RID_HEADER = np.array([0, _RID_FRAME.id, _RID_FRAME.crc_extra], dtype=np.int64)


def _crc_extra_by_id() -> NDArray[np.int16]:
    """Each message id's CRC extra, -1 where the dialect has no such id (``scan_packets``)."""
    table = np.full(max(mav.mavlink_map) + 1, -1, dtype=np.int16)
    for msg_id, cls in mav.mavlink_map.items():
        table[msg_id] = cls.crc_extra
    table.setflags(write=False)
    return table


_CRC_EXTRA_BY_ID = _crc_extra_by_id()
#: ``feed`` checks a datagram of this many bytes or more in one ``scan_packets`` call: about
#: 0.6 us a call, against about 0.7 us saved per packet (a heartbeat alone is 21 bytes).
_SCAN_FROM_BYTES = 64


@quick_init
@dataclass(frozen=True, slots=True)
class Received:
    """One accepted MAVLink message."""

    src_system: int
    src_component: int
    message: m.Message
    signed: bool


@dataclass
class LinkCounters:
    """What a link accepted and what it dropped, by reason."""

    accepted: int = 0
    bad_data: int = 0
    truncated: int = 0
    unknown_id: int = 0
    unhandled: int = 0
    invalid_value: int = 0
    rejected_signature: int = 0
    last_error: str = ""
    #: ``invalid_value`` drops of decoded messages by ``"MESSAGE.field"`` (``codec.inbound``)
    invalid_fields: dict[str, int] = field(default_factory=dict)

    @property
    def dropped(self) -> int:
        return (
            self.bad_data
            + self.truncated
            + self.unknown_id
            + self.invalid_value
            + self.rejected_signature
        )


class MavlinkLink:
    """One end of a MAVLink 2 link, sans I/O.

    ``src_system`` / ``src_component`` stamp outgoing packets. With ``signing`` set, every
    outgoing packet is signed and incoming packets must carry a valid signature: unsigned
    or wrongly signed ones are dropped and counted in ``counters.rejected_signature``.
    """

    def __init__(
        self,
        src_system: int,
        src_component: int,
        signing: SigningConfig | None = None,
        replay: ReplayWindow | None = None,
        columnar: bool = False,
    ) -> None:
        """``replay``: the anti-replay state to check against; links of one core that share
        a key share one (``ReplayWindow``), so a stream replayed through another socket is
        still seen as old. Default: this link's own. ``columnar``: consecutive messages of a
        kind with a columnar decoding (``wire.Layout.decode_rows``: RIDSAFE_OBSERVATION and
        RIDSAFE_OBSERVATION_PACK, RIDSAFE_RID_FRAME) from one sender in one ``feed`` come as
        one ``Received`` of their rows (``messages.ObservationRows``, ``RidFrameReports``),
        decoded together; each message still counts as accepted."""
        self._columnar = columnar
        self._system, self._component, self._seq = src_system, src_component, 0
        self._incompat_flags = 0 if signing is None else IFLAG_SIGNED
        self._pending = b""
        self.counters = LinkCounters()
        self.signing = signing
        self._signing = None if signing is None else SigningState(signing, replay)

    @property
    def src_system(self) -> int:
        return self._system

    @property
    def src_component(self) -> int:
        return self._component

    def pack(self, message: m.Message) -> bytes:
        """Encode one message as one MAVLink 2 packet and advance the sequence number: the
        bytes pymavlink's ``pack`` produces, without its per-packet objects. Raises
        WireError for a message whose values do not fit its fields."""
        return self.frame(encode_payload(message))

    def frame(self, payload: Payload) -> bytes:
        """One packet of an encoded payload (``wire.encode_payload``) from this link: its
        sequence number, its identity, its signature."""
        msg_id, crc_extra, data = payload
        seq = self._seq
        self._seq = (seq + 1) & 0xFF
        packet = (
            HEADER.pack(
                STX_V2,
                len(data),
                self._incompat_flags,
                0,
                seq,
                self._system,
                self._component,
                msg_id & 0xFFFF,
                msg_id >> 16,
            )
            + data
        )
        packet += x25_crc(packet[1:] + crc_extra).to_bytes(2, "little")
        return packet if self._signing is None else self._signing.sign(packet)

    def frame_all(self, payloads: list[Payload]) -> list[bytes]:
        """``frame`` of each payload, in order (one call for a broadcast's messages: the
        link's state is read and written once, not per packet)."""
        seq, incompat, system, component = (
            self._seq,
            self._incompat_flags,
            self._system,
            self._component,
        )
        signing, pack, out = self._signing, HEADER.pack, []
        for msg_id, crc_extra, data in payloads:
            packet = pack(STX_V2, len(data), incompat, 0, seq, system, component,
                          msg_id & 0xFFFF, msg_id >> 16) + data  # fmt: skip
            seq = (seq + 1) & 0xFF
            packet += x25_crc(packet[1:] + crc_extra).to_bytes(2, "little")
            out.append(packet if signing is None else signing.sign(packet))
        self._seq = seq
        return out

    def advance_signing_clock(self, elapsed_s: float) -> None:
        """With signing: outgoing stamps at least ``initial_timestamp`` plus ``elapsed_s``
        (the core's time since its signing clock started) in 10 us units."""
        if self._signing is not None and elapsed_s > 0.0:
            start = self._signing.config.initial_timestamp
            self._signing.advance_to(start + int(elapsed_s * 100_000))

    def pack_all(self, messages: list[m.Message]) -> bytes:
        return b"".join(self.pack_each(messages))

    def pack_each(self, messages: Sequence[m.Message]) -> list[bytes]:
        """``pack`` of each message, in order (``wire.encode_payloads``: a batch of
        observation packs encoded together). Raises WireError, packing none, when one does
        not fit."""
        return self.frame_all(encode_payloads(messages))

    def feed(self, data: bytes, end_of_datagram: bool = True) -> list[Received]:
        """Parse bytes; return the accepted messages.

        Over UDP a MAVLink packet never spans datagrams, so by default a partial packet left
        at the end of ``data`` is dropped (counted as ``truncated``) instead of swallowing
        the start of the next datagram. Pass ``end_of_datagram=False`` for a byte stream
        (serial, TCP) where packets may be split across reads.
        """
        data = data if type(data) is bytes else bytes(data)
        buf = self._pending + data if self._pending else data
        self._pending = b""
        received: list[Received] = []
        run: list[bytes] = []  # checked packets of one columnar message from one sender
        if len(buf) >= _SCAN_FROM_BYTES:
            ends = np.empty(len(buf) // (HEADER_LEN + CRC_LEN), dtype=np.int64)
            count = scan_packets(np.frombuffer(buf, np.uint8), _CRC_EXTRA_BY_ID, ends)
            if count != NOT_PLAIN:  # whole packets, each id known and each CRC right
                self._take_all(buf, ends[:count].tolist(), run, received)
                return received
        i, n = 0, len(buf)
        while i < n:
            if buf[i] != STX_V2:
                i = self._skip_garbage(buf, i)
                continue
            if n - i < HEADER_LEN + CRC_LEN:
                break
            mlen, incompat = buf[i + 1], buf[i + 2]
            if incompat & ~IFLAG_SIGNED:
                self._drop("bad_data", f"unknown incompat_flags 0x{incompat:02x}")
                i += 1
                continue
            end = i + HEADER_LEN + mlen + CRC_LEN
            if incompat & IFLAG_SIGNED:
                end += SIGNATURE_LEN
            if end > n:
                break
            i += self._take(buf[i:end], mlen, run, received)
        if run:
            self._decode_run(run, received)
        if i < n:
            if end_of_datagram:
                self._drop("truncated", f"{n - i} bytes of a partial packet")
            else:
                self._pending = buf[i:]
        return received

    def valid_senders(self, data: bytes) -> list[tuple[int, int]]:
        """(system, component) of every frame in one datagram that this link would take as
        genuine: a known message id, a matching CRC and, with signing, a genuine and fresh
        signature. Changes no state and counts nothing: for deciding whether a datagram's
        source address may become the link's peer (``common.peer_lock``)."""
        senders: list[tuple[int, int]] = []
        i, n = 0, len(data)
        while i < n:
            i = data.find(b"\xfd", i)
            if i < 0 or n - i < HEADER_LEN + CRC_LEN:
                break
            mlen, incompat = data[i + 1], data[i + 2]
            end = (
                i + HEADER_LEN + mlen + CRC_LEN + (SIGNATURE_LEN if incompat & IFLAG_SIGNED else 0)
            )
            packet_layout = layout(data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16)
            if incompat & ~IFLAG_SIGNED or end > n or packet_layout is None:
                i += 1
                continue
            packet = data[i:end]
            crc_end = HEADER_LEN + mlen
            crc = packet[crc_end] | packet[crc_end + 1] << 8
            if crc != x25_crc(packet[1:crc_end] + packet_layout.crc_extra_byte):
                i += 1
                continue
            if self._signing is None or (
                len(packet) > crc_end + CRC_LEN
                and self._signing.genuine_and_fresh(packet, packet[5], packet[6])
            ):
                senders.append((packet[5], packet[6]))
            i = end
        return senders

    def _skip_garbage(self, buf: bytes, i: int) -> int:
        """Drop bytes up to the next MAVLink 2 start marker; returns where it is."""
        j = buf.find(b"\xfd", i + 1)
        j = len(buf) if j < 0 else j
        what = "a MAVLink 1 packet (MAVLink 2 only)" if buf[i] == STX_V1 else "garbage"
        self._drop("bad_data", f"{j - i} bytes of {what}")
        return j

    def _take(self, packet: bytes, mlen: int, run: list[bytes], received: list[Received]) -> int:
        """Check one complete packet and decode it into ``received``, or, with columnar
        decoding, add it to ``run`` (decoded once the run ends); returns bytes consumed."""
        consumed, packet_layout = self._check_packet(packet, mlen)
        if packet_layout is not None:
            self._take_checked(packet, packet_layout, run, received)
        return consumed

    def _take_all(
        self, buf: bytes, ends: list[int], run: list[bytes], received: list[Received]
    ) -> None:
        """``_take`` of the packets of ``buf`` that end at ``ends``, whose ids and CRCs
        ``scan_packets`` checked: their signatures, then each decoded into ``received``."""
        start = 0
        for end in ends:
            packet = buf[start:end]
            packet_layout = layout(packet[7] | packet[8] << 8 | packet[9] << 16)
            assert packet_layout is not None  # the scan knew its CRC extra
            signed = len(packet) > HEADER_LEN + packet[1] + CRC_LEN
            if self._signing is None or self._signature_ok(packet, signed, packet[5], packet[6]):
                self._take_checked(packet, packet_layout, run, received)
            start = end
        if run:
            self._decode_run(run, received)

    def _take_checked(
        self, packet: bytes, packet_layout: Layout, run: list[bytes], received: list[Received]
    ) -> None:
        """Decode one checked packet into ``received`` or, with columnar decoding, add it to
        ``run`` (decoded once the run ends)."""
        if self._columnar and packet_layout.decode_rows is not None:
            last = run[-1] if run else packet
            if last[5:10] != packet[5:10] or last[2] != packet[2]:  # sender, id, signed
                self._decode_run(run, received)
            run.append(packet)
            return
        if run:
            self._decode_run(run, received)
        item = self._decoded(packet_layout, packet, packet[1])
        if item is not None:
            received.append(item)

    def _check_packet(self, packet: bytes, mlen: int) -> tuple[int, Layout | None]:
        """Check one complete packet's id, CRC and signature; returns (bytes consumed, its
        layout, or None when it is dropped).

        A packet whose CRC does not match consumes one byte only, so a false start marker
        inside garbage cannot hide the real packet that follows.
        """
        src_system, src_component = packet[5], packet[6]
        msg_id = packet[7] | packet[8] << 8 | packet[9] << 16
        packet_layout = layout(msg_id)
        if packet_layout is None:
            self._drop("unknown_id", f"unknown message id {msg_id} from {src_system}")
            return len(packet), None
        crc_end = HEADER_LEN + mlen
        crc = packet[crc_end] | packet[crc_end + 1] << 8
        if crc != x25_crc(packet[1:crc_end] + packet_layout.crc_extra_byte):
            self._drop("bad_data", f"CRC mismatch in message {msg_id} from {src_system}")
            return 1, None
        if self.signing is not None and not self._signature_ok(
            packet, len(packet) > crc_end + CRC_LEN, src_system, src_component
        ):
            return len(packet), None
        return len(packet), packet_layout

    def _decoded(self, packet_layout: Layout, packet: bytes, mlen: int) -> Received | None:
        """The message of a checked packet, or None (counted) when the apps do not use it
        or a value is one no valid sender produces."""
        crc_end = HEADER_LEN + mlen
        message = self._decode_message(packet_layout, packet[HEADER_LEN:crc_end], packet)
        if message is False:
            return None
        if message is None:
            self.counters.unhandled += 1
            logger.debug("ignoring %s from %d", packet_layout.name, packet[5])
            return None
        self.counters.accepted += 1
        return Received(packet[5], packet[6], message, len(packet) > crc_end + CRC_LEN)

    def _decode_run(self, run: list[bytes], received: list[Received]) -> None:
        """Decode checked packets of one columnar message from one sender (``run``, emptied)
        into one ``Received`` of their rows; when any row is not plainly valid, each packet
        on its own, as any other message, so that each is kept or dropped and counted by
        itself."""
        first = run[0]
        packet_layout = layout(first[7] | first[8] << 8 | first[9] << 16)
        assert packet_layout is not None and packet_layout.decode_rows is not None
        rows = packet_layout.decode_rows([p[HEADER_LEN : HEADER_LEN + p[1]] for p in run])
        if rows is not None and (isinstance(rows, m.RidFrameReports) or rows_valid(rows)):
            self.counters.accepted += len(run)
            received.append(Received(first[5], first[6], rows, bool(first[2] & IFLAG_SIGNED)))
        else:
            for packet in run:
                item = self._decoded(packet_layout, packet, packet[1])
                if item is not None:
                    received.append(item)
        run.clear()

    def _decode_message(self, packet_layout: Layout, payload: bytes, packet: bytes) -> Any:
        """The domain message of a checked packet; None: the apps do not use it; False:
        a value no valid sender produces (dropped and counted by message and field)."""
        if packet_layout.decode is None:
            return None
        if packet_layout.decode_known is not None and packet_layout.remember is not None:
            return self._decode_by_tail(packet_layout, payload, packet)
        if not packet_layout.remembered:
            return self._decode_fresh(packet_layout, payload, packet)
        key = (packet_layout.name, payload)
        known = _DECODED.get(key)
        if known is not None:
            return known
        message = self._decode_fresh(packet_layout, payload, packet)
        if message is not None and message is not False:
            if len(_DECODED) >= DECODED_MEMO_SIZE:
                _DECODED.clear()
            _DECODED[key] = message
        return message

    def _decode_by_tail(self, packet_layout: Layout, payload: bytes, packet: bytes) -> Any:
        """``_decode_message`` of a message with a per-receiver head (``Layout.decode_known``):
        the rest decoded once while remembered, every message still checked at the edge."""
        assert packet_layout.decode_known is not None and packet_layout.remember is not None
        known = packet_layout.decode_known(payload)
        if known is None:
            message = self._decode_fresh(packet_layout, payload, packet)
            if message is not None and message is not False:
                packet_layout.remember(payload, message)
            return message
        bad_field = first_invalid_field(known)
        if bad_field is not None:
            self._reject_field(packet_layout.name, bad_field, packet[5], packet[6], "out of range")
            return False
        return known

    def _decode_fresh(self, packet_layout: Layout, payload: bytes, packet: bytes) -> Any:
        """``_decode_message`` without the memo."""
        name, decode = packet_layout.name, packet_layout.decode
        if decode is None:
            return None
        try:
            message = decode(packet_layout.view(payload))
        except (WireError, ValueError, TypeError, UnicodeDecodeError, OverflowError) as exc:
            self._reject_field(name, "decode", packet[5], packet[6], str(exc))
            return False
        if message is not None:
            bad_field = first_invalid_field(message)
            if bad_field is not None:
                self._reject_field(name, bad_field, packet[5], packet[6], "out of range")
                return False
        return message

    def _signature_ok(self, packet: bytes, signed: bool, system: int, component: int) -> bool:
        """With a key: a valid, fresh signature is required (``SigningState.check``).
        Without a key: anything goes."""
        if self._signing is None:
            return True
        if not signed:
            self._drop("rejected_signature", f"unsigned packet from {system}/{component}")
            return False
        reason = self._signing.check(packet, system, component)
        if reason is not None:
            self._drop("rejected_signature", reason)
            return False
        return True

    def _reject_field(
        self, name: str, bad_field: str, system: int, component: int, why: str
    ) -> None:
        key = f"{name}.{bad_field}"
        self.counters.invalid_fields[key] = self.counters.invalid_fields.get(key, 0) + 1
        self._drop("invalid_value", f"{key} from {system}/{component}: {why}")

    def _drop(self, kind: str, reason: str) -> None:
        """Count a drop; warn on the first of each kind and then every 1000th (a stream of
        garbage must not flood the log), debug otherwise."""
        count = getattr(self.counters, kind) + 1
        setattr(self.counters, kind, count)
        self.counters.last_error = reason
        level = logging.WARNING if count == 1 or count % 1000 == 0 else logging.DEBUG
        logger.log(
            level,
            "link %d/%d dropped %s (%d so far): %s",
            self.src_system,
            self.src_component,
            kind,
            count,
            reason,
        )


def warm_up_columnar() -> m.ObservationRows:
    """Load (or compile) the kernels of a columnar link's decoding before a run needs them:
    two reports through a real link, alone and in a pack; returns their rows."""
    sender, receiver = MavlinkLink(1, 1), MavlinkLink(2, 1, columnar=True)
    report = m.Observation(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -70.0, None, None, None, "W")
    alone = sender.pack(report) + sender.pack(report)
    packed = sender.pack(m.ObservationPack((report, report)))
    rows = [r.message for r in receiver.feed(alone + packed)]
    singles = rows[0]
    if not isinstance(singles, m.ObservationRows) or [type(r) for r in rows] != [type(singles)] * 2:
        raise AssertionError(f"the warm-up's reports came as {rows!r}")
    return singles


@functools.cache
def warm_up_batches() -> None:
    """Load (or compile) the kernels of the batched encodings once per process, before a run
    needs them: a companion's batch of reports (``wire.encode_payloads``), a datagram's
    packets checked together (``scan_packets``) and the sim's RID frame reports framed
    together (``frame_rid_reports``)."""
    report = m.Observation(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -70.0, None, None, None, "W")
    link = MavlinkLink(1, 1)
    MavlinkLink(2, 1).feed(link.pack_each([m.ObservationRows.of([report])])[0])
    tails = RidFrameTails.of([m.RidFrameReport(b"\x12" + bytes(24), 0.0, b"W", 3)])
    frame_rid_reports([link], [1], tails, np.zeros(1, np.int64), np.array([-70.0]))


def frame_rid_reports(
    links: Sequence[MavlinkLink],
    counts: Sequence[int],
    tails: RidFrameTails,
    tail_of: NDArray[np.int64],
    rssi_dbm: NDArray[np.float64],
) -> list[list[bytes]] | None:
    """The packets each link's ``pack`` makes of RIDSAFE_RID_FRAME reports, framed together
    (``frame_kernels.frame_headed``): report i of frame ``tail_of[i]`` (``tails``) with
    strength ``rssi_dbm[i]``, the first ``counts[0]`` through ``links[0]``, the next
    ``counts[1]`` through ``links[1]``... (each link's sequence numbers advance). None,
    framing none, when a link signs or a strength does not fit a float32: the caller then
    sends the reports as messages."""
    if any(link.signing is not None for link in links) or not np.all(np.abs(rssi_dbm) < _F32_MAX):
        return None
    n = int(rssi_dbm.shape[0])
    if n == 0:
        return [[] for _ in links]
    per_link = np.array([[link._seq, link._system, link._component] for link in links], np.int64)
    count = np.array(counts, dtype=np.int64)
    first = np.cumsum(count) - count
    ids = np.repeat(per_link, count, axis=0)
    ids[:, 0] += np.arange(n) - np.repeat(first, count)
    out = np.empty(int(tails.length[tail_of].sum()) + n * _RID_PACKET_OVERHEAD, dtype=np.uint8)
    ends = np.empty(n, dtype=np.int64)
    frame_headed(rssi_dbm.astype(np.float32), tails.joined, tails.start, tails.length, tail_of,
                 ids, _RID_HEADER, out, ends)  # fmt: skip
    raw, bounds = out[: ends[-1]].tobytes(), [0, *ends.tolist()]
    packets: list[list[bytes]] = []
    for link, start, k in zip(links, first.tolist(), counts, strict=True):
        link._seq = (link._seq + k) & 0xFF
        packets.append([raw[bounds[i] : bounds[i + 1]] for i in range(start, start + k)])
    return packets
