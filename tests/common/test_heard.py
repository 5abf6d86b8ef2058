"""Heard RID frames: decoding single frames and packs, errors, the shared decoder, and the
equality of what a companion reads with what the sender meant (up to F3411 quantisation)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec, f3411, rid
from ridsafe.common import messages as m
from ridsafe.common.heard import HeardRidFrame, RidFrameDecoder, decode_rid_frame

SENDER = b"RSAF800000007"


def _frame(message: m.Message) -> bytes:
    return f3411.encode(*codec.odid_fields(message))


def _state(lat: float = 36.1, unix_s: float = 1_767_268_812.3) -> rid.OwnState:
    return rid.OwnState(unix_s, lat, -86.8, 230.0, 50.0, (3.0, 4.0, -1.0), True)


def test_a_heard_frame_keeps_frame_rssi_and_sender_together() -> None:
    report = m.RidFrameReport(b"\x12" + bytes(24), -71.5, SENDER, int(m.RidTransport.WIFI_NAN), 6)
    heard = HeardRidFrame(4.25, report)
    assert (heard.rx_t_s, heard.rssi_dbm, heard.sender_id) == (4.25, -71.5, SENDER)
    assert heard.frame == report.frame


def test_a_single_location_decodes_with_the_sender_as_id() -> None:
    decoded = decode_rid_frame(_frame(rid.location(_state())), SENDER)
    (loc,) = decoded.locations()
    assert decoded.errors == () and decoded.msg_type == int(m.OdidMessageType.LOCATION)
    assert loc.id_or_mac == SENDER
    assert loc.lat_deg == pytest.approx(36.1, abs=1e-7)


def test_a_pack_decodes_every_message_and_names_the_one_that_does_not() -> None:
    good = [_frame(rid.basic_id("RSAF800000007")), _frame(rid.location(_state()))]
    pack = bytearray(f3411.pack(good))
    decoded = decode_rid_frame(bytes(pack), SENDER)
    assert [type(x) for x in decoded.messages] == [m.OdidBasicId, m.OdidLocation]
    assert decoded.msg_type == int(m.OdidMessageType.MESSAGE_PACK)
    pack[3 + 25] = 0x1F  # the second message's header: LOCATION, protocol version 15
    broken = decode_rid_frame(bytes(pack), SENDER)
    assert [type(x) for x in broken.messages] == [m.OdidBasicId]
    assert len(broken.errors) == 1 and broken.errors[0].startswith("message 1")


@pytest.mark.parametrize("frame", [b"", b"\x12\x00", b"\x72" + bytes(24)])
def test_unreadable_frames_give_an_error_not_an_exception(frame: bytes) -> None:
    decoded = decode_rid_frame(frame, SENDER)
    assert decoded.messages == () and decoded.errors


def test_the_decoder_remembers_by_frame_and_sender_and_stays_bounded() -> None:
    decoder = RidFrameDecoder(max_entries=2)
    frame = _frame(rid.location(_state()))
    first = decoder.decode(frame, SENDER)
    assert decoder.decode(frame, SENDER) is first
    other = decoder.decode(frame, b"OTHER")
    assert other.locations()[0].id_or_mac == b"OTHER"
    decoder.decode(_frame(rid.location(_state(lat=36.2))), SENDER)  # full: starts over
    assert decoder.decode(frame, SENDER) == first and decoder.decode(frame, SENDER) is not first


@settings(max_examples=200)
@given(
    lat=st.floats(-89.0, 89.0),
    unix_s=st.floats(1.7e9, 1.8e9),
    v=st.tuples(st.floats(-30.0, 30.0), st.floats(-30.0, 30.0), st.floats(-10.0, 10.0)),
)
def test_decoding_off_the_air_equals_the_old_mavlink_hand_over(
    lat: float, unix_s: float, v: tuple[float, float, float]
) -> None:
    """What the companion reads from the frame equals what it read when the transponder
    decoded the frame and sent it as OPEN_DRONE_ID_LOCATION (the domain message survives a
    MAVLink round trip unchanged), so observations are unchanged by the move."""
    state = rid.OwnState(unix_s, lat, -86.8, 230.0, 50.0, v, True)
    (direct,) = decode_rid_frame(_frame(rid.location(state)), SENDER).locations()
    tx, rx = codec.MavlinkLink(1, 236), codec.MavlinkLink(1, 191)
    (via_mavlink,) = rx.feed(tx.pack(direct))
    assert via_mavlink.message == direct
