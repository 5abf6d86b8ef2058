"""The MAVLink codec: round trips up to the wire's quantisation, hostile input, signing."""

from __future__ import annotations

import math
import random
import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError

F32_REL = 1e-6  # float32 fields: relative error of one rounding


def _link_pair(
    signing_a: codec.SigningConfig | None = None, signing_b: codec.SigningConfig | None = None
) -> tuple[codec.MavlinkLink, codec.MavlinkLink]:
    return codec.MavlinkLink(1, 1, signing_a), codec.MavlinkLink(255, 190, signing_b)


def _round_trip(message: m.Message) -> m.Message:
    tx, rx = _link_pair()
    received = rx.feed(tx.pack(message))
    assert rx.counters.dropped == 0, rx.counters
    assert len(received) == 1
    assert received[0].src_system == 1 and received[0].src_component == 1
    return received[0].message


def _close(a: float, b: float, abs_tol: float) -> bool:
    return math.isclose(a, b, rel_tol=F32_REL, abs_tol=abs_tol)


finite = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)
lat = st.floats(min_value=-90, max_value=90, allow_nan=False)
lon = st.floats(min_value=-180, max_value=180, allow_nan=False)
vec = st.tuples(finite, finite, finite)
#: Inside the edge's physical limits (codec.inbound): altitudes from -1 km, speeds to 300 m/s.
alt_m = st.floats(min_value=-1e3, max_value=1e4, allow_nan=False)
speed = st.floats(min_value=-300, max_value=300, allow_nan=False)
velocity = st.tuples(speed, speed, speed)
var = st.floats(0, 1e5)  # a variance is never negative
cross = st.floats(-1e5, 1e5)
uas_id = st.text(alphabet="ABCDEFGHJKLMNPRSTUVWXYZ0123456789", min_size=1, max_size=20)
times = st.floats(min_value=0, max_value=4e6, allow_nan=False)


@settings(max_examples=200)
@given(t=times, la=lat, lo=lon, alt=alt_m, rel=finite, v=velocity)
def test_global_position_int_round_trip_within_wire_scales(
    t: float, la: float, lo: float, alt: float, rel: float, v: m.Vec3
) -> None:
    sent = m.GlobalPositionInt(t, la, lo, alt, rel, v, 123.45)
    got = _round_trip(sent)
    assert isinstance(got, m.GlobalPositionInt)
    assert abs(got.lat_deg - la) <= 0.5e-7 + 1e-12
    assert abs(got.lon_deg - lo) <= 0.5e-7 + 1e-12
    assert abs(got.alt_msl_m - alt) <= 0.0005 + 1e-9  # mm
    assert abs(got.relative_alt_m - rel) <= 0.0005 + 1e-9
    assert all(abs(a - b) <= 0.005 + 1e-9 for a, b in zip(got.v_ned_m_s, v, strict=True))
    assert got.heading_deg == pytest.approx(123.45, abs=0.005)
    assert abs(got.time_boot_s - t) <= 0.0005 + 1e-9


@settings(max_examples=200)
@given(t=times, p=vec, v=velocity, mask=st.sampled_from(list(m.PositionTargetMask)))
def test_set_position_target_round_trip(t: float, p: m.Vec3, v: m.Vec3, mask: int) -> None:
    sent = m.SetPositionTargetLocalNed(t, 3, 1, m.MavFrame.LOCAL_NED, mask, p, v, (0, 0, 0), 1, 0)
    got = _round_trip(sent)
    assert isinstance(got, m.SetPositionTargetLocalNed)
    assert got.type_mask == int(mask) and got.target_system == 3
    assert all(_close(a, b, 1e-3) for a, b in zip(got.p_ned_m, p, strict=True))
    assert all(_close(a, b, 1e-3) for a, b in zip(got.v_ned_m_s, v, strict=True))


@settings(max_examples=200)
@given(
    t=times,
    rx=st.tuples(lat, lon, alt_m),
    claimed=st.tuples(lat, lon, alt_m),
    rssi=st.floats(-150, 30),
    course=st.none() | st.floats(0, 359.99),
    speed_h=st.none() | st.floats(0, 254),
    speed_v=st.none() | st.floats(-62, 62),
    sid=uas_id,
)
def test_observation_round_trip(
    t: float,
    rx: m.Vec3,
    claimed: m.Vec3,
    rssi: float,
    course: float | None,
    speed_h: float | None,
    speed_v: float | None,
    sid: str,
) -> None:
    sent = m.Observation(t, *rx, *claimed, 1799.5, rssi, course, speed_h, speed_v, sid)
    got = _round_trip(sent)
    assert isinstance(got, m.Observation)
    assert got.uas_id == sid
    assert abs(got.rx_lat_deg - rx[0]) <= 0.5e-7 + 1e-12
    assert abs(got.claimed_lon_deg - claimed[1]) <= 0.5e-7 + 1e-12
    assert _close(got.claimed_alt_m, claimed[2], 1e-3)
    assert _close(got.rssi_dbm, rssi, 1e-5)
    assert abs(got.t_s - t) <= 0.5e-6 + 1e-9
    assert (got.claimed_course_deg is None) == (course is None)
    if course is not None and got.claimed_course_deg is not None:
        assert abs(got.claimed_course_deg - course) <= 0.005 + 1e-9 or course > 359.995
    assert (got.claimed_speed_horizontal_m_s is None) == (speed_h is None)
    assert (got.claimed_speed_vertical_m_s is None) == (speed_v is None)


@settings(max_examples=100)
@given(
    reports=st.lists(
        st.tuples(times, st.tuples(lat, lon, alt_m), st.floats(-150, 30), uas_id),
        min_size=1,
        max_size=3,
    )
)
def test_an_observation_pack_decodes_to_what_its_reports_decode_to_one_by_one(
    reports: list[tuple[float, m.Vec3, float, str]],
) -> None:
    """RIDSAFE_OBSERVATION_PACK: the rows are each report's own round trip, in order."""
    sent = [
        m.Observation(t, *p, *p, 1799.5, rssi, None if k == 1 else 90.0, 5.0, -1.0, sid)
        for k, (t, p, rssi, sid) in enumerate(reports)
    ]
    got = _round_trip(m.ObservationPack(tuple(sent)))
    assert isinstance(got, m.ObservationRows)
    assert got.observations() == [_round_trip(o) for o in sent]


def test_an_observation_pack_of_none_or_four_is_refused_on_the_way_out() -> None:
    report = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, 0.0, 1.0, 0.0, "A"
    )
    for reports in ((), (report,) * 4):
        with pytest.raises(WireError, match="observation pack"):
            codec.to_mavlink(m.ObservationPack(reports))


@settings(max_examples=100)
@given(
    la=lat,
    lo=lon,
    cov=st.tuples(var, cross, cross, var, cross, var),  # xx xy xz yy yz zz
    vel=st.tuples(*[st.floats(-50, 50)] * 3),
    sid=uas_id,
)
def test_unsafe_region_round_trip(
    la: float, lo: float, cov: tuple[float, ...], vel: m.Vec3, sid: str
) -> None:
    cov6 = (cov[0], cov[1], cov[2], cov[3], cov[4], cov[5])
    sent = m.UnsafeRegionMsg(10.25, 11.0, la, lo, 80.0, cov6, vel, 7.815, 0.05, 7, 2, sid)
    got = _round_trip(sent)
    assert isinstance(got, m.UnsafeRegionMsg)
    assert got.uas_id == sid and got.track_id == 7 and got.flags == 2
    assert all(_close(a, b, 1e-3) for a, b in zip(got.cov_ned_m2, cov6, strict=True))
    assert all(_close(a, b, 1e-5) for a, b in zip(got.v_ned_m_s, vel, strict=True))
    assert got.valid_until_s == 11.0


@settings(max_examples=200)
@given(
    la=lat,
    lo=lon,
    course=st.none() | st.floats(0, 359.99),
    speed=st.none() | st.floats(0, 254.25),
    alt=st.none() | st.floats(-999, 30000),
    ts=st.none() | st.floats(0, 3599.9),
)
def test_odid_location_round_trip(
    la: float,
    lo: float,
    course: float | None,
    speed: float | None,
    alt: float | None,
    ts: float | None,
) -> None:
    if round(la * 1e7) == 0 and round(lo * 1e7) == 0:
        la = 1e-6  # (0, 0) degE7 is the wire's "unknown position"
    sent = m.OdidLocation(
        b"SN1", 2, course, speed, None, la, lo, None, alt, 0, alt, 1, 2, 3, 4, ts, 5
    )
    got = _round_trip(sent)
    assert isinstance(got, m.OdidLocation)
    assert got.id_or_mac == b"SN1" and got.status == 2 and got.speed_vertical_m_s is None
    assert got.lat_deg is not None and abs(got.lat_deg - la) <= 0.5e-7 + 1e-12
    assert (got.course_deg is None) == (course is None)
    assert (got.speed_horizontal_m_s is None) == (speed is None)
    if speed is not None and got.speed_horizontal_m_s is not None:
        assert abs(got.speed_horizontal_m_s - speed) <= 0.005 + 1e-9
    assert (got.alt_geodetic_m is None) == (alt is None)
    assert (got.timestamp_s is None) == (ts is None)


# One of every domain message the codec knows (the OdidRaw pack comes from a real encoding).
EVERY_MESSAGE: list[m.Message] = [
    m.Heartbeat(14, 3, 217, 4, 4),
    m.CommandLong(1, 1, 22, 0, (0, 0, 0, math.nan, 0, 0, 30)),
    m.CommandAck(22, 4, 255, 190),
    m.SetMode(1, 1, 4),
    m.LocalPositionNed(1.0, (1.0, 2.0, -3.0), (0.5, 0.25, 0.0)),
    m.Attitude(1.0, 0.5, -0.25, 1.5, (0.0, 0.125, 0.5)),
    m.SysStatus(1, 1, 1, 10.0, 16.8, 90),
    m.HomePosition(47.0, 8.0, 400.0, (0.0, 0.0, 0.0)),
    m.SystemTime(1_700_000_000.0, 2.0),
    m.StatusText(4, "Arm: Need GUIDED"),
    m.OdidBasicId(b"SN1", 1, 2, b"1581F4ABC"),
    m.OdidSystem(b"", 1, 0, 47.0, 8.0, 1, 0, None, None, 0, 0, 400.0, 12345),
    m.OdidSystemUpdate(47.0, 8.0, 400.0, 12346),
    m.OdidOperatorId(b"", 0, "OPERATOR1"),
    m.OdidSelfId(b"", 0, "delivery"),
    m.OdidArmStatus(0, ""),
    m.RidFrameReport(bytes(range(1, 26)), -71.25, b"SN1", int(m.RidTransport.SIMULATED), 37),
    m.RidFrameReport(b"\xf2\x19\x01" + bytes(25), -90.5, b"", 0),
    m.SpoofAlert(5.0, 10.0, 6.5, 1, 1, "SPOOF1"),
    m.LockstepTick(0.02, 2),
    m.LockstepDone(0.02, 2),
    m.GlobalPositionInt(1.5, 47.0, 8.0, 400.0, 30.0, (1.0, -0.5, 0.25), 123.45),
    m.SetPositionTargetLocalNed(
        1.5, 3, 1, m.MavFrame.LOCAL_NED, 3520, (1.0, 2.0, -3.0), (0.5, 0.0, 0.0), (0, 0, 0), 0, 0
    ),
    m.OdidLocation(
        b"SN1", 2, 90.0, 7.25, -0.5, 47.0, 8.0, None, 430.0, 0, 30.0, 1, 2, 3, 4, 12.5, 5
    ),
    m.Observation(
        12.5, 47.0, 8.0, 430.0, 47.001, 8.001, 440.0, 12.5, -71.25, 90.0, 7.25, -0.5, "S"
    ),
    m.UnsafeRegionMsg(
        1.0, 2.0, 47.0, 8.0, 60.0, (1, 0, 0, 1, 0, 1), (1, 2, 3), 7.75, 0.0625, 3, 0, "S"
    ),
    m.OdidRaw(
        "OPEN_DRONE_ID_MESSAGE_PACK",
        (
            ("target_system", 0),
            ("target_component", 0),
            ("id_or_mac", tuple(range(1, 21))),
            ("single_message_size", 25),
            ("msg_pack_size", 2),
            ("messages", tuple(i % 256 for i in range(225))),
        ),
    ),
]


def test_every_domain_message_survives_the_wire() -> None:
    messages = EVERY_MESSAGE
    for sent in messages:
        got = _round_trip(sent)
        assert type(got) is type(sent)
        if isinstance(sent, m.CommandLong):
            assert isinstance(got, m.CommandLong) and math.isnan(got.params[3])
            continue
        assert got == sent, (sent, got)


def test_sequence_numbers_advance_per_packet() -> None:
    tx, _ = _link_pair()
    seqs = [tx.pack(m.LockstepTick(0.0, i))[4] for i in range(300)]
    assert seqs[:3] == [0, 1, 2] and seqs[256] == 0 and seqs[299] == 43


def test_stream_split_at_every_byte_still_parses() -> None:
    tx, rx = _link_pair()
    data = tx.pack_all([m.LockstepTick(0.1, 1), m.Heartbeat(18, 8, 0, 0, 4)])
    got: list[codec.Received] = []
    for i in range(len(data)):
        got.extend(rx.feed(data[i : i + 1], end_of_datagram=False))
    assert [type(r.message) for r in got] == [m.LockstepTick, m.Heartbeat]


def test_garbage_truncated_and_corrupt_frames_are_counted_and_parsing_resumes() -> None:
    tx, rx = _link_pair()
    good = tx.pack(m.LockstepTick(1.0, 7))
    corrupt = bytearray(tx.pack(m.LockstepTick(2.0, 8)))
    corrupt[-1] ^= 0xFF  # checksum
    truncated = tx.pack(m.LockstepTick(3.0, 9))[:-4]
    got = rx.feed(b"\x00\x01garbage" + bytes(corrupt) + good)
    assert [r.message for r in got] == [m.LockstepTick(1.0, 7)]
    assert rx.counters.bad_data >= 2
    # In a byte stream a truncated frame swallows what follows until its length is
    # satisfied; the parser must recover on the frames after that.
    later = [tx.pack(m.LockstepTick(4.0 + i, 10 + i)) for i in range(3)]
    got = rx.feed(truncated + b"".join(later), end_of_datagram=False)
    assert m.LockstepTick(6.0, 12) in [r.message for r in got]
    assert rx.counters.accepted >= 2


def test_a_partial_packet_at_the_end_of_a_datagram_does_not_eat_the_next_datagram() -> None:
    tx, rx = _link_pair()
    truncated = tx.pack(m.LockstepTick(3.0, 9))[:-4]
    assert rx.feed(truncated) == []
    assert rx.counters.truncated == 1
    got = rx.feed(tx.pack(m.LockstepTick(4.0, 10)))
    assert [r.message for r in got] == [m.LockstepTick(4.0, 10)]


def test_unknown_message_id_is_counted_not_raised() -> None:
    payload = b"\x01\x02\x03"
    header = struct.pack("<BBBBBBBHB", 0xFD, len(payload), 0, 0, 0, 9, 1, 0xFFFF, 0x00)
    frame = header + payload + b"\x00\x00"
    _, rx = _link_pair()
    assert rx.feed(frame) == []
    assert rx.counters.unknown_id + rx.counters.bad_data == 1


def test_out_of_range_latitude_is_rejected_with_reason() -> None:
    raw = mav.MAVLink_global_position_int_message(0, 910_000_000, 0, 0, 0, 0, 0, 0, 0)
    tx = mav.MAVLink(None, srcSystem=3, srcComponent=1)
    _, rx = _link_pair()
    assert rx.feed(bytes(raw.pack(tx))) == []
    assert rx.counters.invalid_value == 1
    assert "latitude 91.0" in rx.counters.last_error


def test_nan_rssi_is_rejected() -> None:
    raw = mav.MAVLink_ridsafe_rid_frame_message(math.nan, [0] * 20, 1, 0, 25, [0x12] * 228)
    tx = mav.MAVLink(None, srcSystem=3, srcComponent=236)
    _, rx = _link_pair()
    assert rx.feed(bytes(raw.pack(tx))) == []
    assert rx.counters.invalid_value == 1


@pytest.mark.parametrize("frame_len", [0, 229, 255])
def test_rid_frame_length_outside_the_field_is_rejected(frame_len: int) -> None:
    raw = mav.MAVLink_ridsafe_rid_frame_message(-70.0, [0] * 20, 1, 0, frame_len, [1] * 228)
    tx = mav.MAVLink(None, srcSystem=3, srcComponent=236)
    _, rx = _link_pair()
    assert rx.feed(bytes(raw.pack(tx))) == []
    assert rx.counters.invalid_value == 1


def test_rid_frame_keeps_trailing_zero_bytes_and_the_largest_pack() -> None:
    """A frame ending in zeros comes back whole (frame_len, not the padding, says where it
    ends), and a 9-message pack (228 bytes) fits the 255-byte payload."""
    tx, rx = _link_pair()
    for frame in (b"\x12" + bytes(24), bytes(range(228))):
        report = m.RidFrameReport(frame, -80.0, b"SN-7", int(m.RidTransport.WIFI_NAN), 6)
        (got,) = rx.feed(tx.pack(report))
        assert got.message == report


def test_rid_frame_too_long_is_refused_on_the_way_out() -> None:
    tx, _ = _link_pair()
    with pytest.raises(WireError):
        tx.pack(m.RidFrameReport(bytes(229), -80.0, b"", 0))


def test_message_without_domain_class_is_ignored_and_counted() -> None:
    raw = mav.MAVLink_ping_message(0, 0, 0, 0)  # PING: no domain class
    tx = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    _, rx = _link_pair()
    assert rx.feed(bytes(raw.pack(tx))) == []
    assert rx.counters.unhandled == 1 and rx.counters.dropped == 0


KEY = bytes(range(32))


def test_signed_link_accepts_signed_and_rejects_unsigned_and_forged() -> None:
    signing = codec.SigningConfig(KEY, initial_timestamp=1000)
    tx, rx = _link_pair(signing, codec.SigningConfig(KEY))
    got = rx.feed(tx.pack(m.SpoofAlert(5.0, 1.0, 1.0, 0, 1, "S")))
    assert len(got) == 1 and got[0].signed

    unsigned = codec.MavlinkLink(7, 191)
    assert rx.feed(unsigned.pack(m.SpoofAlert(5.0, 1.0, 1.0, 0, 1, "S"))) == []
    forger = codec.MavlinkLink(7, 191, codec.SigningConfig(bytes(32), initial_timestamp=5000))
    assert rx.feed(forger.pack(m.SpoofAlert(5.0, 1.0, 1.0, 0, 1, "S"))) == []
    assert rx.counters.rejected_signature == 2


def test_replayed_signed_packet_is_rejected() -> None:
    tx, rx = _link_pair(codec.SigningConfig(KEY, 1000), codec.SigningConfig(KEY))
    packet = tx.pack(m.LockstepTick(0.5, 1))
    assert len(rx.feed(packet)) == 1
    assert rx.feed(packet) == []
    assert rx.counters.rejected_signature == 1


def test_signing_timestamps_are_judged_as_pymavlink_judges_them() -> None:
    """Replays, streams that go back in time and new streams more than a minute behind the
    receiver's clock are refused exactly when pymavlink's ``check_signature`` refuses them."""
    rng = random.Random(7)
    start = 10**9
    ours = codec.MavlinkLink(1, 1, codec.SigningConfig(KEY, initial_timestamp=start))
    reference = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    reference.signing.secret_key = KEY
    reference.signing.timestamp = start
    clocks: dict[tuple[int, int], int] = {}  # per stream: newest timestamp sent
    verdicts = []
    for _ in range(400):
        system, link_id = rng.choice([(7, 0), (7, 1), (8, 0), (9, 2), (9, 3), (10, 0)])
        first = start + rng.randint(-7_000_000, 1_000_000)  # a new stream: up to 70 s behind
        timestamp = clocks.get((system, link_id), first) + rng.randint(-3, 10)
        clocks[(system, link_id)] = max(timestamp, clocks.get((system, link_id), timestamp))
        sender = codec.MavlinkLink(system, 191, codec.SigningConfig(KEY, timestamp, link_id))
        packet = sender.pack(m.LockstepTick(0.0, 1))
        accepted = len(ours.feed(packet)) == 1
        assert accepted == reference.check_signature(bytearray(packet), system, 191)
        verdicts.append(accepted)
    assert 50 < sum(verdicts) < 350  # both kinds of verdict were exercised


def test_signing_key_file_hex_and_passphrase(tmp_path: Path) -> None:
    hex_file = tmp_path / "hex.key"
    hex_file.write_text(KEY.hex())
    assert codec.load_signing_key(hex_file) == KEY
    phrase = tmp_path / "phrase.key"
    phrase.write_text("correct horse battery staple\n")
    key = codec.load_signing_key(phrase)
    assert len(key) == 32 and key != KEY


def test_odid_fields_match_mavlink_field_names_and_round_trip() -> None:
    loc = m.OdidLocation(
        b"SN1", 2, 90.0, 4.0, 0.5, 47.0, 8.0, None, 450.0, 0, 30.0, 10, 4, 0, 3, 12.5, 1
    )
    name, fields = codec.odid_fields(loc)
    assert name == "OPEN_DRONE_ID_LOCATION"
    assert fields["latitude"] == 470_000_000 and fields["direction"] == 9000
    assert fields["speed_horizontal"] == 400 and fields["altitude_barometric"] == -1000.0
    assert codec.message_from_fields(name, fields) == loc


def test_odid_fields_are_the_fields_of_the_pymavlink_message() -> None:
    odid = [msg for msg in EVERY_MESSAGE if type(msg).__name__.startswith("Odid")]
    assert len(odid) >= 7
    for message in odid:
        raw = codec.to_mavlink(message)
        expected = {name: getattr(raw, name) for name in raw.get_fieldnames()}
        expected = {
            k: v.rstrip(b"\x00").decode("latin-1") if isinstance(v, bytes) else v
            for k, v in expected.items()
        }
        name, fields = codec.odid_fields(message)
        assert name == raw.get_type()
        assert fields == {k: list(v) if isinstance(v, tuple) else v for k, v in expected.items()}


def test_a_forged_packet_cannot_block_the_genuine_stream_with_a_future_timestamp() -> None:
    tx, rx = _link_pair(codec.SigningConfig(KEY, 1000), codec.SigningConfig(KEY))
    assert len(rx.feed(tx.pack(m.LockstepTick(0.1, 1)))) == 1
    # Same stream (link 0, system 1, component 1), far-future timestamp, wrong key.
    forger = codec.MavlinkLink(1, 1, codec.SigningConfig(bytes(32), initial_timestamp=10**12))
    assert rx.feed(forger.pack(m.LockstepTick(0.2, 2))) == []
    assert len(rx.feed(tx.pack(m.LockstepTick(0.3, 3)))) == 1  # still accepted
    assert rx.counters.rejected_signature == 1


def test_x25_crc_matches_pymavlink() -> None:
    for payload in (b"", b"\x00", b"123456789", bytes(range(256))):
        assert codec.x25_crc(payload) == mav.x25crc(bytearray(payload)).crc
    assert codec.x25_crc(b"123456789") == 0x6F91  # CRC-16/MCRF4XX check value


def test_packets_are_byte_identical_to_pymavlinks_signed_and_unsigned() -> None:
    messages: list[m.Message] = [
        *EVERY_MESSAGE,  # StatusText: its "id" field must not shadow the message id
        m.HomePosition(47.0, 8.0, 400.0, (1.0, 2.0, 3.0)),
        m.UnsafeRegionMsg(
            1.0, 2.0, 47.0, 8.0, 60.0, (1, 0, 0, 1, 0, 1), (1, 2, 3), 7.8, 0.05, 3, 0, "S"
        ),
        m.LockstepTick(0.0, 0),  # all-zero payload: MAVLink 2 keeps one byte
    ]
    for signing in (None, codec.SigningConfig(KEY, 12345, link_id=2)):
        ours = codec.MavlinkLink(7, 191, signing)
        reference = mav.MAVLink(None, srcSystem=7, srcComponent=191)
        if signing is not None:
            reference.signing.secret_key = KEY
            reference.signing.sign_outgoing = True
            reference.signing.link_id = 2
            reference.signing.timestamp = 12345
        for message in messages * 2:
            expected = bytes(codec.to_mavlink(message).pack(reference))
            reference.seq = (reference.seq + 1) % 256
            assert ours.pack(message) == expected, type(message).__name__


def _sample_value(fieldtype: str, k: int) -> object:
    if fieldtype.startswith("char"):
        return b"rid"[: 1 + k % 3]
    if fieldtype in ("float", "double"):
        return k + 0.5
    return (k * 7 + 1) % 100


def test_every_dialect_message_unpacks_to_the_fields_pymavlink_reads() -> None:
    """The decoder's views (one named tuple type per message id) against pymavlink's own
    decoding, for every message of the dialect: scalars, arrays and char arrays."""
    reference = mav.MAVLink(None, srcSystem=3, srcComponent=1)
    for msg_id, cls in mav.mavlink_map.items():
        args = []
        for i, fieldtype in enumerate(cls.fieldtypes):
            length = cls.array_lengths[cls.orders[i]]
            value = _sample_value(fieldtype, i)
            args.append([value] * length if length and fieldtype != "char" else value)
        packet = bytes(cls(*args).pack(reference))
        expected = reference.decode(bytearray(packet))
        layout = codec.wire.layout(msg_id)
        assert layout is not None
        view = layout.view(packet[10:-2])
        assert view.get_type() == cls.msgname and view.get_fieldnames() == tuple(cls.fieldnames)
        for name in cls.fieldnames:
            want = getattr(expected, name)
            want = want.encode("latin-1") if isinstance(want, str) else want
            got = getattr(view, name)
            assert (list(got) if isinstance(want, list) else got) == want, (cls.msgname, name)
