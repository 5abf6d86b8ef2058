"""Bluetooth LE captures: HCI LE (extended) advertising reports with service data 0xFFFA, in
btsnoop (H4 and the Linux monitor format btmon writes) and pcap, read back to the very F3411
bytes with the controller's RSSI and the capture time.

Oracle: reference encodings (tests/data) inside advertisements scapy builds; the extended
report's event-type bits checked against the Core specification's layout byte by byte.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scapy.layers.bluetooth import (
    HCI_Event_Hdr,
    HCI_Event_LE_Meta,
    HCI_Hdr,
    HCI_LE_Meta_Advertising_Report,
    HCI_LE_Meta_Advertising_Reports,
    HCI_LE_Meta_Extended_Advertising_Report,
)

from ridsafe.common import f3411
from ridsafe.common import messages as m
from ridsafe.common.capture import read_capture, read_capture_file
from ridsafe.common.capture.containers import BTSNOOP_EPOCH_OFFSET_US
from tests.common.capture import builders as b

LOCATIONS = b.reference_messages("OPEN_DRONE_ID_LOCATION", 3)
SELF_IDS = b.reference_messages("OPEN_DRONE_ID_SELF_ID", 1)
OPERATOR_IDS = b.reference_messages("OPEN_DRONE_ID_OPERATOR_ID", 1)
SYSTEMS = b.reference_messages("OPEN_DRONE_ID_SYSTEM", 1)
LEGACY, LONG_RANGE = m.RidTransport.BLUETOOTH_LEGACY, m.RidTransport.BLUETOOTH_LONG_RANGE
T0_NS = b.EPOCH_S * 10**9


def _items() -> list[b.Timed]:
    pack = f3411.pack([SELF_IDS[0], LOCATIONS[1]])
    return [
        b.Timed(0.0, b.plain_advert_event("c0:ff:ee:00:00:01", -30)),
        b.Timed(0.5, b.legacy_report_event("c0:00:00:00:00:01", 17, LOCATIONS[0], -80)),
        b.Timed(0.75, b.extended_report_event("c0:00:00:00:00:02", _data(3, pack), -91)),
    ]


def _data(counter: int, frame: bytes) -> bytes:
    return bytes(b.odid_service_data(counter, frame))


def _expected() -> list[tuple[object, ...]]:
    pack = f3411.pack([SELF_IDS[0], LOCATIONS[1]])
    return [
        (2, T0_NS + 500_000_000, LEGACY, "c0:00:00:00:00:01", -80, 17, LOCATIONS[0]),
        (3, T0_NS + 750_000_000, LONG_RANGE, "c0:00:00:00:00:02", -91, 3, pack),
    ]


def _got(path: Path) -> list[tuple[object, ...]]:
    capture = read_capture_file(path)
    assert not capture.skipped and capture.records == 3
    return [
        (f.record, f.t_unix_ns, f.transport, f.sender_mac, f.rssi_dbm, f.counter, f.frame)
        for f in capture.frames
    ]


def test_btsnoop_h4_gives_legacy_messages_and_extended_packs_with_rssi(tmp_path: Path) -> None:
    assert _got(b.write_btsnoop(tmp_path / "h4.btsnoop", _items())) == _expected()


def test_btsnoop_in_the_monitor_format_btmon_writes_reads_the_same(tmp_path: Path) -> None:
    path = b.write_btsnoop(tmp_path / "mon.btsnoop", _items(), b.BTSNOOP_MONITOR)
    assert _got(path) == _expected()


def test_pcap_and_pcapng_of_hci_h4_read_the_same(tmp_path: Path) -> None:
    assert _got(b.write_pcap(tmp_path / "hci.pcap", _items(), b.LINKTYPE_H4)) == _expected()
    assert _got(b.write_pcapng(tmp_path / "hci.pcapng", _items(), b.LINKTYPE_H4)) == _expected()


def test_the_extended_report_event_type_is_little_endian_with_status_in_bits_5_and_6() -> None:
    report = HCI_LE_Meta_Extended_Advertising_Report(data_status=1, legacy=1)
    assert bytes(report)[:2] == bytes([0x30, 0x00])  # bit 4 legacy, bits 5-6 = 01


def test_an_extended_advertisement_in_parts_is_joined_and_a_truncated_one_dropped(
    tmp_path: Path,
) -> None:
    pack = f3411.pack([SELF_IDS[0], LOCATIONS[2], OPERATOR_IDS[0], SYSTEMS[0]])
    data = _data(5, pack)
    cut = len(data) // 2
    mac = "c0:00:00:00:00:03"
    items = [
        b.Timed(0.0, b.extended_report_event(mac, data[:cut], -70, data_status=1)),
        b.Timed(0.001, b.extended_report_event(mac, data[cut:], -70, data_status=0)),
        b.Timed(0.002, b.extended_report_event(mac, data[:cut], -70, data_status=2)),
    ]
    capture = read_capture_file(b.write_btsnoop(tmp_path / "parts.btsnoop", items))
    assert [(f.record, f.frame) for f in capture.frames] == [(2, pack)]
    assert capture.skipped == {"bluetooth_truncated": 1}


def test_an_advertisement_without_rssi_is_counted_not_reported(tmp_path: Path) -> None:
    items = [b.Timed(0.0, b.legacy_report_event("c0:00:00:00:00:01", 1, LOCATIONS[0], 127))]
    capture = read_capture(b.write_btsnoop(tmp_path / "x", items).read_bytes(), "x.btsnoop")
    assert capture.frames == [] and capture.skipped == {"no_rssi": 1}
    assert capture.problems == ["x.btsnoop: record 1 (byte 16): no_rssi: controller gave RSSI 127"]


@pytest.mark.parametrize("app_code", [0x0C, 0x0E])
def test_service_data_0xfffa_with_another_app_code_is_a_named_problem(
    app_code: int, tmp_path: Path
) -> None:
    data = bytes([2 + 1 + 2 + 25, 0x16, 0xFA, 0xFF, app_code, 1]) + LOCATIONS[0]
    items = [b.Timed(0.0, b.extended_report_event("c0:00:00:00:00:01", data, -60))]
    capture = read_capture_file(b.write_btsnoop(tmp_path / "app.btsnoop", items))
    assert capture.frames == [] and capture.skipped == {"hci_event": 1}
    assert "no app code 0x0D" in capture.problems[0]


FRAMINGS: dict[str, tuple[int, Callable[[bytes], bytes]]] = {
    # pcap 201: direction u32 (1: received) in front of the H4 packet
    "pcap-201": (201, lambda h4: struct.pack(">I", 1) + h4),
    # pcap 254: adapter u16, opcode u16 (3: event), big-endian, then the packet without H4 byte
    "pcap-254": (254, lambda h4: struct.pack(">HH", 0, 3) + h4[1:]),
}


@pytest.mark.parametrize("framing", sorted(FRAMINGS))
def test_pcap_of_hci_with_a_direction_or_monitor_header_reads_the_same(
    framing: str, tmp_path: Path
) -> None:
    link_type, wrap = FRAMINGS[framing]
    items = [b.Timed(item.t_s, wrap(bytes(item.packet))) for item in _items()]
    assert _got(b.write_pcap(tmp_path / "hci.pcap", items, link_type)) == _expected()


def test_btsnoop_without_h4_bytes_reads_received_events_by_the_flags(tmp_path: Path) -> None:
    out = bytearray(b"btsnoop\x00" + struct.pack(">II", 1, 1001))
    for item in _items():
        data = bytes(item.packet)[1:]
        t_us = round((b.EPOCH_S + item.t_s) * 1e6) + BTSNOOP_EPOCH_OFFSET_US
        out += struct.pack(">IIIIq", len(data), len(data), 0x3, 0, t_us) + data
    # a command sent (flags 0x2) with the same bytes is not an event: not read
    out += struct.pack(">IIIIq", len(data), len(data), 0x2, 0, t_us) + data
    capture = read_capture(bytes(out), "u.btsnoop")
    assert capture.records == 4 and len(capture.frames) == 2


@settings(max_examples=40)
@given(
    index=st.integers(0, len(LOCATIONS) - 1),
    dbm=st.integers(-127, 20),
    counter=st.integers(0, 255),
    t_us=st.integers(0, 10**9),
    extended=st.booleans(),
)
def test_any_message_rssi_counter_and_time_come_back_exactly(
    index: int, dbm: int, counter: int, t_us: int, extended: bool
) -> None:
    message = LOCATIONS[index]
    if extended:
        event = b.extended_report_event("c0:00:00:00:00:05", _data(counter, message), dbm)
    else:
        event = b.legacy_report_event("c0:00:00:00:00:05", counter, message, dbm)
    data = bytes(event)
    stamp = t_us + BTSNOOP_EPOCH_OFFSET_US + b.EPOCH_S * 10**6
    raw = b"btsnoop\x00" + struct.pack(">II", 1, 1002)
    raw += struct.pack(">IIIIq", len(data), len(data), 0x3, 0, stamp) + data
    (frame,) = read_capture(raw, "p.btsnoop").frames
    assert (frame.frame, frame.rssi_dbm, frame.counter) == (message, dbm, counter)
    assert frame.t_unix_ns == (b.EPOCH_S * 10**6 + t_us) * 1000
    assert frame.transport is (LONG_RANGE if extended else LEGACY)


def test_two_reports_in_one_event_are_read_one_after_the_other(tmp_path: Path) -> None:
    reports = [
        HCI_LE_Meta_Advertising_Report(
            type=3,
            addr_type=1,
            addr=f"c0:00:00:00:00:0{i}",
            rssi=-60 - i,
            data=[b.odid_service_data(i, LOCATIONS[i])],
        )
        for i in (1, 2)
    ]
    event = HCI_Hdr() / HCI_Event_Hdr() / HCI_Event_LE_Meta()
    event /= HCI_LE_Meta_Advertising_Reports(reports=reports)
    capture = read_capture_file(b.write_btsnoop(tmp_path / "two.btsnoop", [b.Timed(0.0, event)]))
    got = [(f.sender_mac, f.rssi_dbm, f.counter, f.frame) for f in capture.frames]
    assert got == [
        ("c0:00:00:00:00:01", -61, 1, LOCATIONS[1]),
        ("c0:00:00:00:00:02", -62, 2, LOCATIONS[2]),
    ]
