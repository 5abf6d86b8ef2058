"""Capture records -> Remote ID frames with RSSI and time -> frames a companion heard.

Time: every frame keeps its packet's capture time (ns since the Unix epoch). A companion
replays a capture **relative to its first record** (any record, Remote ID or not): a frame
captured ``d`` seconds after the first record is heard at ``start_s + d`` on the
companion's clock (``heard_frames``). The capture's absolute times are not used for
anything else (its F3411 LOCATION timestamps are what they are).

Sender: the radio layer knows a MAC address (``CapturedFrame.sender_mac``). A heard frame's
``sender_id`` is the UAS ID that sender broadcast in a BASIC_ID anywhere in the capture
(serial number preferred, as the sim's radio id is the serial), else the MAC as text
``aa:bb:cc:dd:ee:ff``; the companion reports it as the claimed UAS id (``sender_names``).
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ridsafe.common import f3411
from ridsafe.common import messages as m
from ridsafe.common.capture.bluetooth import (
    HCI_LINK_TYPES,
    BluetoothError,
    ExtendedJoiner,
    hci_event,
    le_reports,
    remote_id_service_data,
)
from ridsafe.common.capture.containers import (
    CaptureFormat,
    LinkType,
    RawRecord,
    RecordProblem,
    detect_format,
    read_records,
)
from ridsafe.common.capture.radiotap import RadiotapError, channel_number, parse_radiotap
from ridsafe.common.capture.wifi import WifiFrameError, remote_id_payloads
from ridsafe.common.errors import RidsafeError
from ridsafe.common.heard import HeardRidFrame

__all__ = [
    "Capture",
    "CapturedFrame",
    "heard_frames",
    "read_capture",
    "read_capture_file",
    "sender_names",
]

logger = logging.getLogger(__name__)

#: The longest F3411 frame: a pack of 9 (what RIDSAFE_RID_FRAME carries).
MAX_FRAME_BYTES = f3411.PACK_HEADER_SIZE + f3411.PACK_MAX_MESSAGES * f3411.MESSAGE_SIZE
FCS_LEN = 4
MAX_PROBLEMS_KEPT = 50
BASIC_ID_SERIAL = 1


@dataclass(frozen=True, slots=True)
class CapturedFrame:
    """One F3411 frame from a capture: where (record number from 1), when (ns since the
    Unix epoch), how, from whom, how strong (dBm), the channel (0: unknown) and the
    sender's message counter."""

    record: int
    t_unix_ns: int
    transport: m.RidTransport
    sender_mac: str
    rssi_dbm: int
    channel: int
    counter: int | None
    frame: bytes


@dataclass
class Capture:
    """What a capture file held: its frames, the first record's time, and what was skipped."""

    source: str
    format: CaptureFormat
    frames: list[CapturedFrame] = field(default_factory=list)
    records: int = 0
    first_t_unix_ns: int | None = None
    skipped: Counter[str] = field(default_factory=Counter)
    problems: list[str] = field(default_factory=list)

    def skip(self, number: int, offset: int, reason: str, detail: str) -> None:
        self.skipped[reason] += 1
        text = f"{self.source}: record {number} (byte {offset}): {reason}: {detail}"
        if len(self.problems) < MAX_PROBLEMS_KEPT:
            self.problems.append(text)
        logger.log(logging.WARNING if self.skipped[reason] == 1 else logging.DEBUG, "%s", text)


def read_capture_file(path: Path | str) -> Capture:
    """:func:`read_capture` of a file (OSError if it cannot be read)."""
    return read_capture(Path(path).read_bytes(), str(path))


def read_capture(data: bytes, source: str) -> Capture:
    """Every Remote ID frame of a capture, in record order. Raises only ``CaptureError``
    (not a capture); record-level trouble is counted in ``Capture.skipped``."""
    capture = Capture(source, detect_format(data, source))
    joiner = ExtendedJoiner()
    for item in read_records(data, source):
        if isinstance(item, RecordProblem):
            capture.skip(item.number, item.offset, item.reason, item.detail)
            continue
        capture.records += 1
        if capture.first_t_unix_ns is None:
            capture.first_t_unix_ns = item.t_unix_ns
        try:  # a record that fails part way gives no frame at all
            capture.frames.extend(list(_record_frames(item, joiner, capture)))
        except (RadiotapError, WifiFrameError, BluetoothError) as exc:
            capture.skip(item.number, item.offset, _REASONS[type(exc)], str(exc))
    if joiner.truncated:
        capture.skipped["bluetooth_truncated"] += joiner.truncated
    return capture


_WIFI = frozenset({LinkType.IEEE802_11_RADIOTAP})
_REASONS: dict[type[ValueError], str] = {
    RadiotapError: "radiotap",
    WifiFrameError: "wifi_frame",
    BluetoothError: "hci_event",
}


def _record_frames(
    record: RawRecord, joiner: ExtendedJoiner, capture: Capture
) -> Iterator[CapturedFrame]:
    if record.link_type in _WIFI:
        yield from _wifi_frames(record, capture)
    elif record.link_type in HCI_LINK_TYPES:
        yield from _bluetooth_frames(record, joiner, capture)
    else:
        capture.skip(record.number, record.offset, "link_type", f"{record.link_type} not read")


def _checked(record: RawRecord, frame: bytes, capture: Capture) -> bool:
    if f3411.MESSAGE_SIZE <= len(frame) <= MAX_FRAME_BYTES:
        return True
    capture.skip(record.number, record.offset, "frame_size", f"F3411 frame of {len(frame)} bytes")
    return False


def _wifi_frames(record: RawRecord, capture: Capture) -> Iterator[CapturedFrame]:
    info = parse_radiotap(record.data)
    end = len(record.data) - (FCS_LEN if info.has_fcs else 0)
    payloads = remote_id_payloads(record.data[info.header_len : end])
    if payloads and info.antenna_signal_dbm is None:
        capture.skip(record.number, record.offset, "no_rssi", "radiotap has no antenna signal")
        return
    channel = channel_number(info.frequency_mhz) if info.frequency_mhz else 0
    for payload in payloads:
        if info.antenna_signal_dbm is not None and _checked(record, payload.frame, capture):
            yield CapturedFrame(
                record.number,
                record.t_unix_ns,
                payload.transport,
                payload.sender_mac,
                info.antenna_signal_dbm,
                channel,
                payload.counter,
                payload.frame,
            )


def _bluetooth_frames(
    record: RawRecord, joiner: ExtendedJoiner, capture: Capture
) -> Iterator[CapturedFrame]:
    event = hci_event(record.link_type, record.data, record.flags)
    if event is None:
        return
    for part in le_reports(event):
        report = joiner.add(part) if part.transport is m.RidTransport.BLUETOOTH_LONG_RANGE else part
        if report is None:
            continue
        found = remote_id_service_data(report.data)
        if found and report.rssi_dbm is None:
            capture.skip(record.number, record.offset, "no_rssi", "controller gave RSSI 127")
            continue
        for counter, frame in found:
            if report.rssi_dbm is not None and _checked(record, frame, capture):
                yield CapturedFrame(
                    record.number,
                    record.t_unix_ns,
                    report.transport,
                    report.address,
                    report.rssi_dbm,
                    0,
                    counter,
                    frame,
                )


def _basic_ids(frame: bytes) -> Iterator[tuple[int, bytes]]:
    """(id type, UAS ID without padding) of each readable BASIC_ID in a frame."""
    try:
        is_pack = f3411.message_type(frame) is f3411.MessageType.MESSAGE_PACK
        parts = f3411.split_pack(frame) if is_pack else [frame]
    except RidsafeError:
        return
    for part in parts:
        if part[0] >> 4 != f3411.MessageType.BASIC_ID:
            continue
        try:
            _name, fields = f3411.decode(part)
        except RidsafeError:
            continue
        raw = fields["uas_id"]
        uas_id = bytes(raw) if isinstance(raw, list) else str(raw).encode("latin-1")
        if uas_id.rstrip(b"\x00"):
            yield int(str(fields["id_type"])), uas_id.rstrip(b"\x00")


def sender_names(frames: Iterable[CapturedFrame]) -> dict[str, bytes]:
    """MAC -> the UAS ID it broadcast (a serial number if it sent one, else its first ID)."""
    names: dict[str, bytes] = {}
    serial: set[str] = set()
    for captured in frames:
        for id_type, uas_id in _basic_ids(captured.frame):
            mac = captured.sender_mac
            if mac in serial:
                continue
            if id_type == BASIC_ID_SERIAL:
                names[mac] = uas_id
                serial.add(mac)
            else:
                names.setdefault(mac, uas_id)
    return names


def heard_frames(capture: Capture, start_s: float = 0.0) -> list[HeardRidFrame]:
    """The capture's frames as a companion hears them: at ``start_s`` plus their time after
    the capture's first record, sender named by ``sender_names`` (else the MAC text)."""
    if capture.first_t_unix_ns is None:
        return []
    names = sender_names(capture.frames)
    first_ns = capture.first_t_unix_ns
    return [
        HeardRidFrame(
            start_s + (captured.t_unix_ns - first_ns) / 1e9,
            m.RidFrameReport(
                captured.frame,
                float(captured.rssi_dbm),
                names.get(captured.sender_mac, captured.sender_mac.encode("ascii")),
                int(captured.transport),
                captured.channel,
            ),
        )
        for captured in capture.frames
    ]
