"""The links' decode memo and batch framing (``codec.link``): a payload decoded once is
handed to every link that receives it again; a payload no valid sender produces is still
refused, counted and never remembered; ``frame_all`` frames as ``frame`` does."""

from __future__ import annotations

import dataclasses
import math

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.codec import link
from ridsafe.common.dialect import ridsafe_v20 as mav


def _region(valid_until_s: float) -> m.UnsafeRegionMsg:
    return m.UnsafeRegionMsg(
        t_s=10.0,
        valid_until_s=valid_until_s,
        center_lat_deg=36.1,
        center_lon_deg=-86.8,
        center_alt_m=60.0,
        cov_ned_m2=(400.0, 10.0, 0.0, 300.0, 0.0, 900.0),
        v_ned_m_s=(1.0, 2.0, 0.0),
        chi2_threshold=7.81,
        alpha=0.05,
        track_id=3,
        flags=0,
        uas_id="RSAF00009",
    )


def test_one_payload_framed_for_many_links_decodes_to_one_message() -> None:
    gcs = [codec.MavlinkLink(255, 190) for _ in range(3)]
    receivers = [codec.MavlinkLink(1, 191) for _ in range(3)]
    region = _region(12.0)
    decoded = []
    for sender, receiver in zip(gcs, receivers, strict=True):
        (received,) = receiver.feed(sender.pack(region))
        decoded.append(received.message)
        assert receiver.counters.accepted == 1
    fresh = codec.MavlinkLink(1, 191)._decode_fresh  # the memo's own reference
    payload = codec.encode_payload(region)
    layout = codec.wire.layout(payload.msg_id)
    assert layout is not None
    assert decoded[0] == fresh(layout, payload.data, b"")
    assert decoded[1] is decoded[0] and decoded[2] is decoded[0]


def test_an_invalid_payload_is_refused_every_time_and_not_remembered() -> None:
    sender = codec.MavlinkLink(255, 190)
    bad = dataclasses.replace(_region(12.0), cov_ned_m2=(-1.0, 0.0, 0.0, 1.0, 0.0, 1.0))
    receivers = [codec.MavlinkLink(1, 191) for _ in range(2)]
    packet = sender.pack(bad)
    for receiver in receivers:
        assert receiver.feed(packet) == []
        assert receiver.counters.invalid_value == 1
        assert receiver.counters.invalid_fields == {"RIDSAFE_UNSAFE_REGION.cov_ned_m2": 1}
    assert all(not (isinstance(v, m.UnsafeRegionMsg) and v.cov_ned_m2[0] < 0)
               for v in link._DECODED.values())  # fmt: skip


def test_the_memo_is_bounded() -> None:
    sender, receiver = codec.MavlinkLink(255, 190), codec.MavlinkLink(1, 191)
    for k in range(link.DECODED_MEMO_SIZE + 10):
        (received,) = receiver.feed(sender.pack(_region(20.0 + k)))
        assert isinstance(received.message, m.UnsafeRegionMsg)
        assert math.isclose(received.message.valid_until_s, 20.0 + k, abs_tol=1e-6)
    assert len(link._DECODED) <= link.DECODED_MEMO_SIZE


def test_frame_all_gives_the_packets_frame_gives_one_at_a_time() -> None:
    key = bytes(range(32))
    for signing in (None, codec.SigningConfig(key, 12345)):
        one, many = codec.MavlinkLink(255, 190, signing), codec.MavlinkLink(255, 190, signing)
        payloads = [codec.encode_payload(_region(12.0 + k)) for k in range(300)]  # seq wraps
        assert many.frame_all(payloads) == [one.frame(p) for p in payloads]
        assert many.pack(_region(1.0)) == one.pack(_region(1.0))  # and the state moved alike


def test_messages_that_never_repeat_are_decoded_alike_and_not_remembered() -> None:
    names = {cls.msgname for cls in mav.mavlink_map.values()}
    assert names >= codec.wire.UNIQUE_PAYLOAD_MESSAGES  # no name that matches nothing
    sender, receiver = codec.MavlinkLink(1, 191), codec.MavlinkLink(255, 190)
    position = m.LocalPositionNed(12.5, (10.0, -20.0, -30.0), (1.0, 2.0, -0.5))
    link._DECODED.clear()
    (first,) = receiver.feed(sender.pack(position))
    (again,) = receiver.feed(sender.pack(position))
    assert first.message == again.message == _decoded_fresh(position)
    assert first.message is not again.message
    assert not link._DECODED
    receiver.feed(sender.pack(_region(12.0)))  # a message that does repeat still is
    assert len(link._DECODED) == 1


def _decoded_fresh(message: m.Message) -> m.Message:
    payload = codec.encode_payload(message)
    layout = codec.wire.layout(payload.msg_id)
    assert layout is not None
    decoded: m.Message = codec.MavlinkLink(1, 191)._decode_fresh(layout, payload.data, b"")
    return decoded


def test_a_frame_heard_by_many_receivers_is_decoded_whole_once_each_with_its_own_rssi() -> None:
    """RIDSAFE_RID_FRAME: the bytes after the signal strength decoded once
    (``wire.known_rid_frame``); each receiver's strength its own, a non-finite one refused
    and counted as before, another frame decoded whole."""
    frame = bytes(range(1, 26))
    sender = codec.MavlinkLink(7, 200)
    got: list[m.RidFrameReport] = []
    for rssi in (-60.5, -71.25, -80.0):
        receiver = codec.MavlinkLink(255, 190)
        (received,) = receiver.feed(sender.pack(m.RidFrameReport(frame, rssi, b"AB12", 1)))
        assert isinstance(received.message, m.RidFrameReport)
        got.append(received.message)
    assert [r.rssi_dbm for r in got] == [-60.5, -71.25, -80.0]
    assert all(r == dataclasses.replace(got[0], rssi_dbm=r.rssi_dbm) for r in got)
    assert got[1].frame is got[0].frame  # from the memo
    receiver = codec.MavlinkLink(255, 190)
    assert receiver.feed(sender.pack(m.RidFrameReport(frame, math.nan, b"AB12", 1))) == []
    assert receiver.counters.invalid_fields == {"RIDSAFE_RID_FRAME.decode": 1}
    other = bytes(range(2, 27))
    (received,) = receiver.feed(sender.pack(m.RidFrameReport(other, -60.5, b"AB12", 1)))
    assert received.message == m.RidFrameReport(other, -60.5, b"AB12", 1)
