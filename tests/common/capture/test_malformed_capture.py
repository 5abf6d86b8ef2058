"""Bad captures: a file that is no capture is refused naming file and offset; a record cut
short, hostile or unreadable is counted and named (file, record, byte offset), the rest is
still read; and no byte string makes the reader raise anything but ``CaptureError``.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scapy.packet import Raw

from ridsafe.common.capture import CaptureError, heard_frames, read_capture
from tests.common.capture import builders as b

LOCATION = b.reference_messages("OPEN_DRONE_ID_LOCATION", 1)[0]
PACK = b.location_pack(LOCATION)
DRONE, PHONE = "02:00:00:00:00:01", "c0:00:00:00:00:01"


def _wifi(tmp_path: Path, count: int = 3, writer: str = "pcap") -> bytes:
    items = [
        b.Timed(0.1 * i, b.beacon("02:00:00:00:00:01", i, PACK, -50 - i)) for i in range(count)
    ]
    if writer == "pcap":
        return b.write_pcap(tmp_path / "w.pcap", items, b.LINKTYPE_RADIOTAP).read_bytes()
    return b.write_pcapng(tmp_path / "w.pcapng", items, b.LINKTYPE_RADIOTAP).read_bytes()


def _ble(tmp_path: Path) -> bytes:
    items = [
        b.Timed(0.1 * i, b.legacy_report_event("c0:00:00:00:00:01", i, LOCATION, -60))
        for i in range(3)
    ]
    return b.write_btsnoop(tmp_path / "b.btsnoop", items).read_bytes()


@pytest.mark.parametrize(
    ("data", "complaint"),
    [
        (b"", "rid.cap: byte 0: not a pcap, pcapng or btsnoop file (starts empty)"),
        (b"GIF89a..", "rid.cap: byte 0: not a pcap"),
        (struct.pack("<I", 0xA1B2C3D4) + bytes(4), "rid.cap: byte 0: pcap header needs 24 bytes"),
        (b"btsnoop\x00" + struct.pack(">II", 2, 1002), "rid.cap: byte 8: btsnoop version 1"),
        (b"btsnoop\x00" + struct.pack(">II", 1, 1003), "rid.cap: byte 12: btsnoop datalink 1003"),
        (struct.pack("<III", 0x0A0D0D0A, 28, 0x12345678), "rid.cap: byte 8: byte-order magic"),
    ],
)
def test_a_file_that_is_no_capture_is_refused_naming_file_and_offset(
    data: bytes, complaint: str
) -> None:
    with pytest.raises(CaptureError) as caught:
        read_capture(data, "rid.cap")
    assert str(caught.value).startswith(complaint)


def test_a_record_cut_short_at_the_end_is_counted_and_the_others_kept(tmp_path: Path) -> None:
    data = _wifi(tmp_path)
    capture = read_capture(data[:-10], "cut.pcap")
    assert len(capture.frames) == 2 and capture.skipped == {"truncated": 1}
    (problem,) = capture.problems
    third = 24 + 2 * (len(data) - 24) // 3  # the records are the same size
    assert problem.startswith(f"cut.pcap: record 3 (byte {third}): truncated: record needs")


def test_an_le_meta_event_of_length_zero_is_skipped_and_named(tmp_path: Path) -> None:
    """H4 event 0x3E with parameter length 0 (and a stray byte) has no subevent code (the
    fuzz test found it raising IndexError)."""
    good = bytes(b.legacy_report_event(PHONE, 1, LOCATION, -60))
    items = [b.Timed(0.0, Raw(b"\x04\x3e\x00\x02")), b.Timed(0.1, Raw(good))]
    capture = read_capture(b.write_btsnoop(tmp_path / "z.btsnoop", items).read_bytes(), "z")
    assert len(capture.frames) == 1
    assert sum(capture.skipped.values()) == 1
    assert "subevent" in capture.problems[0]


def test_a_hostile_record_length_stops_the_file_without_reading_past_it(tmp_path: Path) -> None:
    data = bytearray(_wifi(tmp_path))
    record_2 = 24 + (len(data) - 24) // 3
    struct.pack_into("<I", data, record_2 + 8, 0x7FFFFFFF)  # incl_len
    capture = read_capture(bytes(data), "h.pcap")
    assert len(capture.frames) == 1 and capture.skipped == {"hostile": 1}
    assert capture.problems[0].startswith(f"h.pcap: record 2 (byte {record_2}): hostile")


def test_a_broken_radiotap_or_802_11_frame_is_skipped_and_reading_goes_on(tmp_path: Path) -> None:
    data = bytearray(_wifi(tmp_path))
    record_1 = 24 + 16
    struct.pack_into("<H", data, record_1 + 2, 4000)  # radiotap length beyond the packet
    record_2 = 24 + (len(data) - 24) // 3
    oui_at = data.index(bytes.fromhex("fa0bbc0d"), record_2)
    data[oui_at - 1] = 0xFF  # the vendor element's length: runs past the frame's end
    capture = read_capture(bytes(data), "b.pcap")
    assert len(capture.frames) == 1 and capture.frames[0].record == 3
    assert capture.skipped == {"radiotap": 1, "wifi_frame": 1}


def test_a_pcapng_block_of_impossible_length_is_named(tmp_path: Path) -> None:
    data = bytearray(_wifi(tmp_path, writer="pcapng"))
    shb_len = struct.unpack_from("<I", data, 4)[0]
    idb_len = struct.unpack_from("<I", data, shb_len + 4)[0]
    first_packet = shb_len + idb_len
    struct.pack_into("<I", data, first_packet + 4, 13)  # not a multiple of 4
    capture = read_capture(bytes(data), "n.pcapng")
    assert capture.frames == [] and capture.skipped == {"hostile": 1}
    assert capture.problems[0].startswith(f"n.pcapng: record 1 (byte {first_packet}): hostile")


def test_a_packet_on_an_undefined_interface_is_counted(tmp_path: Path) -> None:
    data = bytearray(_wifi(tmp_path, count=1, writer="pcapng"))
    shb_len = struct.unpack_from("<I", data, 4)[0]
    idb_len = struct.unpack_from("<I", data, shb_len + 4)[0]
    struct.pack_into("<I", data, shb_len + idb_len + 8, 5)  # interface id 5
    capture = read_capture(bytes(data), "i.pcapng")
    assert capture.skipped == {"no_interface": 1}


def test_an_unread_link_type_is_counted_per_record(tmp_path: Path) -> None:
    items = [b.Timed(0.0, b"\x00" * 40), b.Timed(0.1, b"\x00" * 40)]
    data = b.write_pcap(tmp_path / "eth.pcap", items, 1).read_bytes()  # Ethernet
    capture = read_capture(data, "eth.pcap")
    assert capture.records == 2 and capture.skipped == {"link_type": 2}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> list[bytes]:
    folder = tmp_path_factory.mktemp("seeds")
    return [_wifi(folder), _wifi(folder, writer="pcapng"), _ble(folder)]


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    which=st.integers(0, 2),
    edits=st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), max_size=8),
    cut=st.integers(0, 10_000),
)
def test_no_damage_makes_the_reader_raise_anything_but_capture_error(
    seeds: list[bytes], which: int, edits: list[tuple[int, int]], cut: int
) -> None:
    data = bytearray(seeds[which])
    for position, value in edits:
        data[position % len(data)] = value
    damaged = bytes(data[: max(1, len(data) - cut % len(data))])
    try:
        capture = read_capture(damaged, "fuzz")
    except CaptureError:
        return
    for frame in capture.frames:
        assert 25 <= len(frame.frame) <= 228 and -128 <= frame.rssi_dbm <= 127
    assert len(heard_frames(capture)) == len(capture.frames)
