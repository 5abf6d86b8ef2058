"""The sim RID transponder: domain OPEN_DRONE_ID_* -> ASTM F3411 bytes -> domain + RSSI.

Oracles: MAVLink field values written out by hand (degE7, cm/s, cdeg) fed to the F3411 encoder,
which matches the reference C library byte for byte (tests/common/test_f3411.py); hand-derived
quantised values for what a receiver gets back; and the ARM_STATUS rule (BASIC_ID, SYSTEM and
LOCATION each sent within the last 3 s) checked on both sides of its edges.
"""

from __future__ import annotations

import dataclasses
import math
import struct

import pytest

from ridsafe.common import codec, f3411, rid
from ridsafe.common import messages as m
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.heard import DecodedRidFrame, decode_rid_frame
from ridsafe.sim_backend.transponder import ARM_STATUS_MAX_AGE_S, STATIC_TYPES, Transponder

SERIAL = "RSAF800000001"
# The sender's radio id differs from its serial, so a receiver that copied the uas_id (or its
# own id) into id_or_mac shows.
SENDER_ID = b"\xaa\xbb\xcc\x01\x02\x03"
START_UNIX_S = 1_767_268_800.0  # 2026-01-01T12:00:00Z, a full hour
SYSTEM_TS = int(START_UNIX_S + 12.34) - 1_546_300_800  # seconds since 2019-01-01T00:00:00Z

OWN_STATE = rid.OwnState(
    unix_s=START_UNIX_S + 12.34,
    lat_deg=47.1234567891,
    lon_deg=8.123456789,
    alt_geodetic_m=512.3,
    height_m=30.2,
    v_ned_m_s=(3.0, 4.0, -1.2),  # 5 m/s towards 53.13 deg, climbing 1.2 m/s
    airborne=True,
)


def _pad(raw: bytes, size: int = 20) -> list[int]:
    return list(raw.ljust(size, b"\x00"))


# (domain message, MAVLink name, F3411 type, the MAVLink field values written out by hand)
CASES: list[tuple[str, m.Message, str, int, dict[str, object]]] = [
    (
        "basic_id",
        rid.basic_id(SERIAL),
        "OPEN_DRONE_ID_BASIC_ID",
        0,
        {"id_type": 1, "ua_type": 2, "uas_id": _pad(SERIAL.encode())},
    ),
    (
        "location",
        rid.location(OWN_STATE),
        "OPEN_DRONE_ID_LOCATION",
        1,
        {
            "status": 2,  # airborne
            "direction": 5313,  # atan2(4, 3) = 53.130 deg
            "speed_horizontal": 500,
            "speed_vertical": 120,  # up positive
            "latitude": 471234568,
            "longitude": 81234568,
            "altitude_barometric": -1000.0,  # unknown
            "altitude_geodetic": 512.3,
            "height_reference": 0,
            "height": 30.2,
            "horizontal_accuracy": 11,
            "vertical_accuracy": 5,
            "barometer_accuracy": 0,
            "speed_accuracy": 4,
            "timestamp": 12.3,  # seconds after the full hour, 0.1 s
            "timestamp_accuracy": 1,
        },
    ),
    (
        "system",
        rid.system(START_UNIX_S + 12.34, 47.0001234, -8.5, 401.5),
        "OPEN_DRONE_ID_SYSTEM",
        4,
        {
            "operator_location_type": 0,
            "classification_type": 0,
            "operator_latitude": 470001234,
            "operator_longitude": -85000000,
            "area_count": 1,
            "area_radius": 0,
            "area_ceiling": -1000.0,
            "area_floor": -1000.0,
            "category_eu": 0,
            "class_eu": 0,
            "operator_altitude_geo": 401.5,
            "timestamp": SYSTEM_TS,
        },
    ),
    (
        "operator_id",
        rid.operator_id("OP-1"),
        "OPEN_DRONE_ID_OPERATOR_ID",
        5,
        {"operator_id_type": 0, "operator_id": "OP-1"},
    ),
    (
        "self_id",
        m.OdidSelfId(b"", 1, "survey flight"),
        "OPEN_DRONE_ID_SELF_ID",
        3,
        {"description_type": 1, "description": "survey flight"},
    ),
]
CASE_IDS = [case[0] for case in CASES]


def _on_air(tx: Transponder, now_s: float, message: m.Message) -> bytes | None:
    """The frame the transponder puts on the air for ``message``: at once for LOCATION,
    at its next static slot for the static messages (SYSTEM_UPDATE refreshes SYSTEM)."""
    frame = tx.on_message(now_s, message)
    if frame is not None or not isinstance(message, (*STATIC_TYPES, m.OdidSystemUpdate)):
        return frame
    name = "OPEN_DRONE_ID_SYSTEM"
    if not isinstance(message, m.OdidSystemUpdate):
        name, _ = codec.odid_fields(message)
    return tx.static_frames.get(name)


@pytest.mark.parametrize(("label", "message", "name", "odid_type", "fields"), CASES, ids=CASE_IDS)
def test_each_broadcast_goes_on_the_air_as_its_f3411_bytes(
    label: str, message: m.Message, name: str, odid_type: int, fields: dict[str, object]
) -> None:
    tx = Transponder(1, SENDER_ID)
    frame = _on_air(tx, 0.0, message)
    assert frame is not None
    assert frame == f3411.encode(name, fields)  # the hand-written MAVLink fields
    assert frame == f3411.encode(*codec.odid_fields(message))  # the codec's fields
    assert len(frame) == 25
    assert frame[0] == odid_type << 4 | 2  # type nibble, protocol version 2
    assert tx.counters.encode_rejected == 0
    # LOCATION goes on the air at once; a static message at the next static slot.
    assert tx.counters.sent + len(tx.due_static(0.0)) == 1


def _location(**changes: object) -> m.OdidLocation:
    return dataclasses.replace(rid.location(OWN_STATE), **changes)  # type: ignore[arg-type]


def _system(**changes: object) -> m.OdidSystem:
    base = rid.system(START_UNIX_S, 47.0, 8.0, 400.0)
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


REJECTED: list[tuple[str, m.Message]] = [
    ("latitude above 90", _location(lat_deg=90.5)),
    ("latitude below -90", _location(lat_deg=-90.0000001)),
    ("longitude beyond 180", _location(lon_deg=-180.5)),
    ("status above 15", _location(status=16)),
    ("status beyond uint8", _location(status=300)),
    ("height above 31767.5 m", _location(height_m=32000.0)),
    ("geodetic altitude below -1000 m", _location(alt_geodetic_m=-1200.0)),
    ("timestamp beyond the hour", _location(timestamp_s=3700.0)),
    ("area radius above 2550 m", _system(area_radius_m=3000)),
    ("classification type above 7", _system(classification_type=8)),
    ("ua type above 15", dataclasses.replace(rid.basic_id(SERIAL), ua_type=16)),
]


@pytest.mark.parametrize("message", [case[1] for case in REJECTED], ids=[c[0] for c in REJECTED])
def test_inputs_the_reference_rejects_are_counted_and_not_sent(message: m.Message) -> None:
    tx = Transponder(1, SENDER_ID)
    assert tx.on_message(0.0, message) is None
    assert (tx.counters.sent, tx.counters.encode_rejected) == (0, 1)


def test_a_rejected_location_does_not_count_towards_arming() -> None:
    tx = Transponder(1, SENDER_ID)
    assert _on_air(tx, 0.0, rid.basic_id(SERIAL)) is not None
    assert _on_air(tx, 0.0, _system()) is not None
    assert tx.on_message(0.0, _location(lat_deg=91.0)) is None
    assert tx.arm_status(0.1) == m.OdidArmStatus(1, "missing LOCATION")


def _operator_id_from_the_wire(text: bytes) -> m.Message:
    """An OPEN_DRONE_ID_OPERATOR_ID as a companion's MAVLink link delivers it."""
    raw = mav.MAVLink_open_drone_id_operator_id_message(0, 0, [0] * 20, 0, text)
    data = bytes(raw.pack(mav.MAVLink(None, srcSystem=1, srcComponent=191)))
    (received,) = codec.MavlinkLink(1, 1).feed(data)
    return received.message


@pytest.mark.parametrize(
    "message",
    [_operator_id_from_the_wire(b"OP\xff\xfe"), m.OdidSelfId(b"", 0, "caf\u00e9")],
    ids=["operator_id_from_mavlink", "self_id"],
)
def test_non_ascii_text_is_counted_as_rejected_not_raised(message: m.Message) -> None:
    tx = Transponder(1, SENDER_ID)
    assert tx.on_message(0.0, message) is None
    assert tx.counters.encode_rejected == 1


# --- SYSTEM_UPDATE -------------------------------------------------------------------------

# Every field different from its default, so a field copied from the wrong place shows.
FULL_SYSTEM = m.OdidSystem(
    id_or_mac=b"",
    operator_location_type=1,
    classification_type=1,
    operator_lat_deg=47.0,
    operator_lon_deg=8.0,
    area_count=3,
    area_radius_m=120,
    area_ceiling_m=150.0,
    area_floor_m=10.0,
    category_eu=2,
    class_eu=3,
    operator_alt_geo_m=400.0,
    timestamp_s=220_000_000,
)
UPDATE = m.OdidSystemUpdate(47.0012345, 8.0054321, 455.5, 220_000_060)


def test_system_update_before_any_system_is_ignored() -> None:
    tx = Transponder(1, SENDER_ID)
    assert tx.on_message(0.0, UPDATE) is None
    assert (tx.counters.sent, tx.counters.encode_rejected) == (0, 0)
    assert "SYSTEM" in tx.arm_status(0.0).error


def test_system_update_after_a_system_sends_the_updated_system() -> None:
    tx = Transponder(1, SENDER_ID)
    assert _on_air(tx, 0.0, FULL_SYSTEM) is not None
    frame = _on_air(tx, 1.0, UPDATE)
    assert frame is not None
    expected = {
        "operator_location_type": 1,
        "classification_type": 1,
        "operator_latitude": 470012345,  # from the update
        "operator_longitude": 80054321,  # from the update
        "area_count": 3,
        "area_radius": 120,
        "area_ceiling": 150.0,
        "area_floor": 10.0,
        "category_eu": 2,
        "class_eu": 3,
        "operator_altitude_geo": 455.5,  # from the update
        "timestamp": 220_000_060,  # from the update
    }
    assert frame == f3411.encode("OPEN_DRONE_ID_SYSTEM", expected)


def test_system_update_keeps_the_system_fresh_for_arming() -> None:
    tx = Transponder(1, SENDER_ID)
    tx.on_message(0.0, FULL_SYSTEM)
    tx.on_message(2.5, rid.basic_id(SERIAL))
    tx.on_message(2.5, rid.location(OWN_STATE))
    assert tx.arm_status(3.5).status == 1  # SYSTEM is 3.5 s old
    tx.on_message(3.6, UPDATE)
    assert tx.arm_status(3.7) == m.OdidArmStatus(0, "")


# --- receive ---------------------------------------------------------------------------------

# What a receiver hands its companion for each CASES broadcast: F3411 quantisation applied by
# hand (whole degrees, 0.25 m/s, 0.5 m/s and 0.5 m altitude truncated toward zero, 0.1 s).
RECEIVED: dict[str, m.Message] = {
    "basic_id": m.OdidBasicId(SENDER_ID, 1, 2, SERIAL.encode()),
    "location": m.OdidLocation(
        id_or_mac=SENDER_ID,
        status=2,
        course_deg=53.0,
        speed_horizontal_m_s=5.0,
        speed_vertical_m_s=1.0,
        lat_deg=47.1234568,
        lon_deg=8.1234568,
        alt_baro_m=None,
        alt_geodetic_m=512.0,
        height_reference=0,
        height_m=30.0,
        horizontal_accuracy=11,
        vertical_accuracy=5,
        barometer_accuracy=0,
        speed_accuracy=4,
        timestamp_s=12.3,
        timestamp_accuracy=1,
    ),
    "system": m.OdidSystem(
        SENDER_ID, 0, 0, 47.0001234, -8.5, 1, 0, None, None, 0, 0, 401.5, SYSTEM_TS
    ),
    "operator_id": m.OdidOperatorId(SENDER_ID, 0, "OP-1"),
    "self_id": m.OdidSelfId(SENDER_ID, 1, "survey flight"),
}


def _same(got: m.Message, expected: m.Message) -> bool:
    """Equal, with the LOCATION timestamp compared at float32 precision (it is a float on
    the MAVLink side)."""
    if isinstance(got, m.OdidLocation) and isinstance(expected, m.OdidLocation):
        assert got.timestamp_s is not None and expected.timestamp_s is not None
        if not math.isclose(got.timestamp_s, expected.timestamp_s, abs_tol=1e-5):
            return False
        got = dataclasses.replace(got, timestamp_s=expected.timestamp_s)
    return got == expected


def _received(report: m.RidFrameReport) -> DecodedRidFrame:
    """What the companion reads from a frame its transponder reported."""
    return decode_rid_frame(report.frame, report.sender_id)


@pytest.mark.parametrize(("label", "message", "name", "odid_type", "fields"), CASES, ids=CASE_IDS)
def test_a_received_frame_is_reported_whole_with_its_rssi_and_reads_as_the_message(
    label: str, message: m.Message, name: str, odid_type: int, fields: dict[str, object]
) -> None:
    tx, rx = Transponder(1, SENDER_ID), Transponder(2, b"RSAF800000002")
    frame = _on_air(tx, 0.0, message)
    assert frame is not None
    report = rx.report(frame, SENDER_ID, -71.25)
    assert report == m.RidFrameReport(frame, -71.25, SENDER_ID, int(m.RidTransport.SIMULATED))
    decoded = _received(report)
    assert decoded.msg_type == odid_type and decoded.errors == ()
    (got,) = decoded.messages
    assert _same(got, RECEIVED[label]), got
    assert rx.counters.received == 1


def _pack(*frames: bytes) -> bytes:
    body = b"".join(frames)
    fields = {"single_message_size": 25, "msg_pack_size": len(frames), "messages": list(body)}
    return f3411.encode("OPEN_DRONE_ID_MESSAGE_PACK", fields)


def _frame(message: m.Message) -> bytes:
    return f3411.encode(*codec.odid_fields(message))


def test_a_message_pack_is_reported_whole_with_one_rssi() -> None:
    messages = {label: message for label, message, *_ in CASES}
    pack = _pack(
        _frame(messages["basic_id"]),
        _frame(messages["location"]),
        _frame(messages["operator_id"]),
    )
    rx = Transponder(2, b"RSAF800000002")
    report = rx.report(pack, SENDER_ID, -88.5)
    assert (report.frame, report.rssi_dbm) == (pack, -88.5)
    contents = _received(report)
    assert contents.errors == ()
    assert contents.msg_type == int(m.OdidMessageType.MESSAGE_PACK)
    assert len(contents.messages) == 3
    for got, label in zip(contents.messages, ["basic_id", "location", "operator_id"], strict=True):
        assert _same(got, RECEIVED[label]), got
    located = contents.locations()
    assert len(located) == 1 and _same(located[0], RECEIVED["location"])


def test_static_messages_go_on_the_air_as_one_pack_or_a_frame_each() -> None:
    statics: list[m.Message] = [
        rid.basic_id(SERIAL),
        rid.operator_id("OP-1"),
        m.OdidSelfId(b"", 0, "x"),
    ]
    frames: dict[bool, list[bytes]] = {}
    for as_pack in (True, False):
        tx = Transponder(1, SENDER_ID, static_as_pack=as_pack)
        for message in statics:
            assert tx.on_message(0.0, message) is None
        frames[as_pack] = tx.due_static(0.0)
        assert tx.counters.sent == len(frames[as_pack])
    assert len(frames[False]) == 3
    assert frames[True] == [_pack(*frames[False])]


def test_a_static_message_sent_again_unchanged_or_changed_goes_on_the_air_as_it_is_now() -> None:
    """The transponder keeps the last encoding of each static message type: a repeat must
    give the same frame, a change (even back and forth) the frame of the message now."""
    tx = Transponder(1, SENDER_ID, static_as_pack=False)
    first, second = rid.operator_id("OP-1"), rid.operator_id("OP-2")
    for message in (first, first, second, first):
        tx.on_message(0.0, message)
        assert tx.static_frames == {"OPEN_DRONE_ID_OPERATOR_ID": _frame(message)}
    assert tx.counters.encode_rejected == 0


def test_a_message_pack_from_the_companion_goes_on_the_air_as_a_pack() -> None:
    body = _frame(rid.basic_id(SERIAL)) + _frame(rid.operator_id("OP-1"))
    raw = m.OdidRaw(
        "OPEN_DRONE_ID_MESSAGE_PACK",
        (
            ("target_system", 0),
            ("target_component", 0),
            ("id_or_mac", (0,) * 20),
            ("single_message_size", 25),
            ("msg_pack_size", 2),
            ("messages", tuple(body.ljust(225, b"\x00"))),
        ),
    )
    tx = Transponder(1, SENDER_ID)
    frame = tx.on_message(0.0, raw)
    assert frame == _pack(_frame(rid.basic_id(SERIAL)), _frame(rid.operator_id("OP-1")))
    assert frame is not None and len(frame) == 3 + 2 * 25


def _location_with_latitude(lat_deg_e7: int) -> bytes:
    frame = bytearray(_frame(rid.location(OWN_STATE)))
    struct.pack_into("<i", frame, 5, lat_deg_e7)  # bytes 5-8: latitude
    return bytes(frame)


GARBAGE: list[tuple[str, bytes]] = [
    ("empty", b""),
    ("short location", b"\x12" + bytes(10)),
    ("long location", b"\x12" + bytes(30)),
    ("protocol version 0", bytes(25)),
    ("unknown type 7", b"\x72" + bytes(24)),
    ("pack of 10", b"\xf2\x19\x0a" + bytes(250)),
    ("pack length mismatch", b"\xf2\x19\x02" + bytes(25)),
    ("latitude 95 deg", _location_with_latitude(950_000_000)),
]


@pytest.mark.parametrize("frame", [g[1] for g in GARBAGE], ids=[g[0] for g in GARBAGE])
def test_undecodable_frames_read_as_nothing_with_the_reason(frame: bytes) -> None:
    report = Transponder(2, b"RSAF800000002").report(frame, SENDER_ID, -60.0)
    decoded = _received(report)
    assert decoded.messages == () and len(decoded.errors) == 1


def test_a_bad_message_inside_a_pack_does_not_hide_the_good_ones() -> None:
    pack = _pack(_location_with_latitude(-950_000_000), _frame(rid.basic_id(SERIAL)))
    contents = _received(Transponder(2, b"RSAF800000002").report(pack, SENDER_ID, -60.0))
    assert contents.messages == (RECEIVED["basic_id"],)
    assert len(contents.errors) == 1 and contents.errors[0].startswith("message 0: ")
    assert contents.locations() == []


def test_a_pack_whose_header_lies_reads_as_nothing() -> None:
    pack = bytearray(_pack(_frame(rid.basic_id(SERIAL)), _frame(rid.operator_id("OP-1"))))
    pack[2] = 7  # claims 7 messages, holds 2
    contents = decode_rid_frame(bytes(pack), SENDER_ID)
    assert contents.messages == () and len(contents.errors) == 1


# --- ARM_STATUS and heartbeat ----------------------------------------------------------------


def test_arm_status_needs_basic_id_system_and_location_within_three_seconds() -> None:
    assert ARM_STATUS_MAX_AGE_S == 3.0
    tx = Transponder(1, SENDER_ID)
    assert tx.arm_status(0.0) == m.OdidArmStatus(1, "missing BASIC_ID,LOCATION,SYSTEM")
    tx.on_message(0.0, rid.basic_id(SERIAL))
    tx.on_message(0.5, rid.system(START_UNIX_S, 47.0, 8.0, 400.0))
    tx.on_message(0.7, rid.operator_id("OP-1"))  # not one of the three
    tx.on_message(0.7, m.OdidSelfId(b"", 0, "x"))
    assert tx.arm_status(1.0) == m.OdidArmStatus(1, "missing LOCATION")
    assert tx.ready_error(1.0) == "missing LOCATION"
    tx.on_message(1.0, rid.location(OWN_STATE))
    for now in (1.0, 2.0, 2.99, 3.0):  # BASIC_ID is at most 3 s old
        assert tx.arm_status(now) == m.OdidArmStatus(0, ""), now
        assert tx.ready_error(now) is None
    assert tx.arm_status(3.01) == m.OdidArmStatus(1, "missing BASIC_ID")
    assert tx.arm_status(3.6) == m.OdidArmStatus(1, "missing BASIC_ID,SYSTEM")
    assert tx.arm_status(4.5) == m.OdidArmStatus(1, "missing BASIC_ID,LOCATION,SYSTEM")
    tx.on_message(4.5, rid.basic_id(SERIAL))
    tx.on_message(4.5, rid.system(START_UNIX_S, 47.0, 8.0, 400.0))
    tx.on_message(4.5, rid.location(OWN_STATE))
    assert tx.arm_status(4.6) == m.OdidArmStatus(0, "")


def test_receiving_frames_does_not_make_the_transponder_ready() -> None:
    tx, rx = Transponder(1, SENDER_ID), Transponder(2, b"RSAF800000002")
    for label, message, *_ in CASES:
        frame = _on_air(tx, 0.0, message)
        assert frame is not None, label
        rx.report(frame, SENDER_ID, -50.0)
    assert tx.arm_status(0.1).status == 0
    assert rx.arm_status(0.1).status == 1


def test_heartbeat_is_an_odid_component() -> None:
    hb = Transponder(3, SENDER_ID).heartbeat()
    assert hb.mav_type == 34  # MAV_TYPE_ODID
    assert hb.autopilot == 8  # MAV_AUTOPILOT_INVALID: not a flight controller
    assert hb.system_status == int(m.MavState.ACTIVE)
    assert not hb.armed


def test_static_messages_go_on_the_air_every_three_seconds_whatever_the_companion_does() -> None:
    tx = Transponder(1, SENDER_ID, static_phase_s=0.5)
    sent: list[tuple[float, int]] = []
    for k in range(0, 1001):  # 10 s; the companion refreshes BASIC_ID every 0.1 s
        t = k * 0.01
        if k % 10 == 0:
            assert tx.on_message(t, rid.basic_id(SERIAL)) is None
        sent.extend((t, f[0] >> 4) for f in tx.due_static(t))
    assert [round(t, 2) for t, _ in sent] == [0.5, 3.5, 6.5, 9.5]
    assert {kind for _, kind in sent} == {0}  # BASIC_ID only: nothing else was given
    assert tx.on_message(10.0, rid.location(OWN_STATE)) is not None  # positions: at once
