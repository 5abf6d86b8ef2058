"""Wi-Fi captures: beacons with the F3411 vendor element and NAN service discovery frames,
in pcap and pcapng with radiotap, read back to the very F3411 bytes with RSSI and time.

Oracles: the reference encodings (tests/data) put into the frames; scapy's own radiotap
dissector for the signal strength; hand-built radiotap headers, laid out from the radiotap
specification, for extended bitmasks, alignment, vendor namespaces and TLVs.
"""

from __future__ import annotations

import hashlib
import struct
from collections.abc import Callable
from pathlib import Path

import pytest
from scapy.layers.dot11 import Dot11, Dot11EltVendorSpecific, RadioTap
from scapy.packet import Raw

from ridsafe.common import codec, f3411
from ridsafe.common import messages as m
from ridsafe.common.capture import CaptureFormat, heard_frames, read_capture_file
from ridsafe.common.capture.radiotap import RadiotapError, channel_number, parse_radiotap
from ridsafe.common.capture.wifi import NAN_REMOTE_ID_SERVICE_ID
from ridsafe.common.rid import basic_id
from tests.common.capture import builders as b

LOCATIONS = b.reference_messages("OPEN_DRONE_ID_LOCATION", 4)
DRONE, OTHER = "02:00:00:00:00:01", "02:00:00:00:00:02"

Write = Callable[[Path, list[b.Timed], int], Path]
WRITERS: dict[str, Write] = {"pcap": b.write_pcap, "pcapng": b.write_pcapng}


def test_the_nan_service_id_is_the_hash_of_the_opendroneid_service_name() -> None:
    assert NAN_REMOTE_ID_SERVICE_ID == b.NAN_SERVICE_ID
    assert hashlib.sha256(b"org.opendroneid.remoteid").digest()[:6] == b.NAN_SERVICE_ID


@pytest.mark.parametrize("container", sorted(WRITERS))
def test_beacons_and_nan_frames_come_back_with_their_pack_rssi_channel_counter_and_time(
    container: str, tmp_path: Path
) -> None:
    packs = [b.location_pack(loc) for loc in LOCATIONS]
    items = [
        b.Timed(0.0, b.plain_beacon("00:11:22:33:44:55", -40)),
        b.Timed(0.25, b.beacon(DRONE, 7, packs[0], -61)),
        b.Timed(0.5, b.beacon(DRONE, 8, packs[1], -62, fcs=True)),
        b.Timed(0.75, b.nan_frame(OTHER, 9, packs[2], -70)),
        b.Timed(1.125, b.nan_frame(OTHER, 10, packs[3], -71, service_control=0x54)),
    ]
    capture = read_capture_file(WRITERS[container](tmp_path / "rid", items, b.LINKTYPE_RADIOTAP))
    assert capture.format is CaptureFormat(container)
    assert capture.records == 5 and not capture.skipped
    got = [
        (
            f.record,
            f.t_unix_ns,
            f.transport,
            f.sender_mac,
            f.rssi_dbm,
            f.channel,
            f.counter,
            f.frame,
        )
        for f in capture.frames
    ]
    beacon, nan, t0 = m.RidTransport.WIFI_BEACON, m.RidTransport.WIFI_NAN, b.EPOCH_S * 10**9
    assert got == [
        (2, t0 + 250_000_000, beacon, DRONE, -61, 6, 7, packs[0]),
        (3, t0 + 500_000_000, beacon, DRONE, -62, 6, 8, packs[1]),
        (4, t0 + 750_000_000, nan, OTHER, -70, 6, 9, packs[2]),
        (5, t0 + 1_125_000_000, nan, OTHER, -71, 6, 10, packs[3]),
    ]
    heard = heard_frames(capture, start_s=100.0)
    assert [h.rx_t_s for h in heard] == [100.25, 100.5, 100.75, 101.125]
    assert [h.sender_id for h in heard] == [DRONE.encode()] * 2 + [OTHER.encode()] * 2


def test_a_sender_is_named_by_the_serial_its_basic_id_gives_once_heard_anywhere(
    tmp_path: Path,
) -> None:
    serial = "RSAF800000007"
    basic = f3411.encode(*codec.odid_fields(basic_id(serial)))
    items = [
        b.Timed(0.0, b.beacon(DRONE, 1, b.location_pack(LOCATIONS[0]), -50)),  # before BASIC_ID
        b.Timed(1.0, b.beacon(DRONE, 2, b.location_pack(LOCATIONS[1], basic), -50)),
        b.Timed(2.0, b.beacon(OTHER, 3, b.location_pack(LOCATIONS[2]), -50)),
    ]
    capture = read_capture_file(b.write_pcap(tmp_path / "rid.pcap", items, b.LINKTYPE_RADIOTAP))
    names = [h.sender_id for h in heard_frames(capture)]
    assert names == [serial.encode(), serial.encode(), OTHER.encode()]


def test_nanosecond_pcap_keeps_nanoseconds(tmp_path: Path) -> None:
    items = [b.Timed(0.000000123, b.beacon(DRONE, 1, b.location_pack(LOCATIONS[0]), -50))]
    path = b.write_pcap(tmp_path / "ns.pcap", items, b.LINKTYPE_RADIOTAP, nano=True)
    (frame,) = read_capture_file(path).frames
    assert frame.t_unix_ns == b.EPOCH_S * 10**9 + 123


@pytest.mark.parametrize(
    "present",
    [
        "dBm_AntSignal",
        "TSFT+Flags+Rate+Channel+dBm_AntSignal+dBm_AntNoise+Antenna",
        "Flags+Channel+dBm_AntSignal+Lock_Quality+RXFlags",  # (scapy writes no FHSS bytes)
        "TSFT+Channel+dBm_AntSignal+MCS+A_MPDU",
    ],
)
def test_the_signal_agrees_with_scapys_dissector_whatever_fields_come_before_it(
    present: str,
) -> None:
    packet = RadioTap(bytes(RadioTap(present=present, dBm_AntSignal=-77, ChannelFrequency=5180)))
    info = parse_radiotap(bytes(packet))
    assert info.antenna_signal_dbm == packet.dBm_AntSignal == -77
    assert info.header_len == packet.len


def _radiotap(masks: list[int], fields: bytes) -> bytes:
    body = b"".join(struct.pack("<I", mask) for mask in masks) + fields
    return struct.pack("<BBH", 0, 0, 4 + len(body)) + body


EXT, RADIOTAP_NS, VENDOR_NS, TLV = 1 << 31, 1 << 29, 1 << 30, 1 << 28
TSFT, FLAGS, CHANNEL, SIGNAL, ANTENNA = 1 << 0, 1 << 1, 1 << 3, 1 << 5, 1 << 11


def test_extended_bitmasks_align_tsft_from_the_header_start_and_take_the_first_signal() -> None:
    # Two bitmasks (header 12 bytes): TSFT aligns to 16; the second bitmask (radiotap
    # namespace again) holds a per-antenna signal that must not replace the combined one.
    fields = bytes(4) + struct.pack("<Q", 1) + struct.pack("<b", -60) + bytes([0])
    fields += struct.pack("<bB", -65, 1)
    header = _radiotap([TSFT | SIGNAL | ANTENNA | RADIOTAP_NS | EXT, SIGNAL | ANTENNA], fields)
    info = parse_radiotap(header)
    assert (info.antenna_signal_dbm, info.header_len) == (-60, len(header))


def test_a_vendor_namespace_is_skipped_by_its_length_and_the_radiotap_one_resumes() -> None:
    # bitmask 0: Flags, vendor namespace next; bitmask 1 (vendor): 5 bytes of vendor data,
    # radiotap namespace next; bitmask 2: Channel, antenna signal.
    flags = bytes([0x10])  # FCS at the end
    vendor = bytes(1) + bytes.fromhex("001122") + bytes([0]) + struct.pack("<H", 5)
    fields = flags + vendor + b"VVVVV" + bytes(1) + struct.pack("<HH", 2412, 0xA0)
    fields += struct.pack("<b", -42)
    masks = [FLAGS | VENDOR_NS | EXT, 0b1 | RADIOTAP_NS | EXT, CHANNEL | SIGNAL]
    info = parse_radiotap(_radiotap(masks, fields))
    assert (info.antenna_signal_dbm, info.frequency_mhz, info.has_fcs) == (-42, 2412, True)


def test_a_tlv_signal_is_read_when_no_bitmask_field_gives_one() -> None:
    tlvs = struct.pack("<HH", 3, 4) + struct.pack("<HH", 2437, 0)  # channel TLV
    tlvs += struct.pack("<HHb", 5, 1, -55) + bytes(3)  # antenna signal TLV, padded to 4
    info = parse_radiotap(_radiotap([FLAGS | TLV], bytes([0]) + bytes(3) + tlvs))
    assert info.antenna_signal_dbm == -55


@pytest.mark.parametrize(
    ("header", "complaint"),
    [
        (struct.pack("<BBH", 1, 0, 8) + bytes(4), "version"),
        (struct.pack("<BBHI", 0, 0, 64, SIGNAL), "length 64"),
        (struct.pack("<BBHI", 0, 0, 8, EXT), "bitmask 1"),
        (struct.pack("<BBHI", 0, 0, 8, 1 << 27), "runs past"),
    ],
)
def test_broken_radiotap_headers_are_refused_with_the_reason(header: bytes, complaint: str) -> None:
    with pytest.raises(RadiotapError, match=complaint):
        parse_radiotap(header)


@pytest.mark.parametrize(
    ("mhz", "channel"), [(2412, 1), (2437, 6), (2484, 14), (5180, 36), (5955, 1), (900, 0)]
)
def test_channel_numbers(mhz: int, channel: int) -> None:
    assert channel_number(mhz) == channel


def test_a_frame_with_ht_control_has_its_body_four_bytes_later(tmp_path: Path) -> None:
    pack = b.location_pack(LOCATIONS[0])
    packet = bytes(b.beacon(DRONE, 4, pack, -66))
    header_at = parse_radiotap(packet).header_len
    frame = bytearray(packet[header_at:])
    frame[1] |= 0x80  # +HTC / order: HT control follows the 24-byte header
    with_htc = packet[:header_at] + bytes(frame[:24]) + bytes(4) + bytes(frame[24:])
    items = [b.Timed(0.0, with_htc)]
    capture = read_capture_file(b.write_pcap(tmp_path / "htc.pcap", items, b.LINKTYPE_RADIOTAP))
    assert [(f.frame, f.rssi_dbm) for f in capture.frames] == [(pack, -66)]


def test_data_frames_and_other_vendors_elements_are_ignored_an_empty_rid_element_named(
    tmp_path: Path,
) -> None:
    data_frame = b.radiotap(-50) / Dot11(type=2, subtype=0, addr2=DRONE) / Raw(bytes(40))
    wpa = Dot11EltVendorSpecific(oui=0x0050F2, info=bytes([0x01, 0x01, 0x00]))
    other_vendor = b.plain_beacon(DRONE, -50) / wpa
    empty_rid = b.beacon(DRONE, 1, b"", -50)  # counter, no message pack
    items = [b.Timed(0.0, data_frame), b.Timed(0.1, other_vendor), b.Timed(0.2, empty_rid)]
    capture = read_capture_file(b.write_pcap(tmp_path / "o.pcap", items, b.LINKTYPE_RADIOTAP))
    assert capture.records == 3 and capture.frames == []
    assert capture.skipped == {"wifi_frame": 1}
    assert (
        "record 3" in capture.problems[0] and "no message counter and pack" in capture.problems[0]
    )
