"""uint8 arrays packed as one ``Ns`` item (``registry.wire_struct``): the same bytes as the
dialect's own struct for every message, and the RID frame decoded from a bytes view."""

from __future__ import annotations

import random

import pytest

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.codec.registry import byte_arrays, wire_struct, wire_values
from ridsafe.common.codec.units import Wire
from ridsafe.common.codec.wire import BYTES_VIEW_MESSAGES, _encoded, layout
from ridsafe.common.dialect import ridsafe_v20 as mav
from ridsafe.common.errors import WireError


def _grouped(cls: object, values: tuple[object, ...]) -> list[object]:
    """The dialect struct's items regrouped as ``wire_struct`` takes them."""
    arrays = byte_arrays(cls)
    out: list[object] = []
    i = 0
    for w, length in enumerate(cls.lengths):  # type: ignore[attr-defined]
        if w in arrays:
            out.append(bytes(values[i : i + length]))  # type: ignore[arg-type]
        else:
            out.extend(values[i : i + length])
        i += length
    return out


@pytest.mark.parametrize("msg_id", sorted(mav.mavlink_map))
def test_wire_struct_packs_the_dialect_structs_bytes(msg_id: int) -> None:
    cls = mav.mavlink_map[msg_id]
    rng = random.Random(msg_id)
    for _ in range(3):
        payload = bytes(rng.randrange(256) for _ in range(cls.unpacker.size))
        values = cls.unpacker.unpack(payload)
        assert wire_struct(cls).pack(*_grouped(cls, values)) == cls.unpacker.pack(*values)


def test_a_rid_frame_report_round_trips_through_the_bytes_view() -> None:
    frame = bytes([0x12, 0x00, 0x34]) + bytes(22) + b"\x00\x00"  # trailing zeros kept
    report = m.RidFrameReport(frame, -71.5, b"\x00\x11\x22\x33\x44\x55", 1, 6)
    sender = codec.MavlinkLink(3, 236)
    receiver = codec.MavlinkLink(3, 191)
    (received,) = receiver.feed(sender.pack(report))
    assert received.message == report
    assert "RIDSAFE_RID_FRAME" in BYTES_VIEW_MESSAGES
    view_layout = layout(mav.MAVLINK_MSG_ID_RIDSAFE_RID_FRAME)
    assert view_layout is not None and view_layout.unpacker.format == "<f20sBBB228s"


def test_a_uint8_array_of_the_wrong_length_is_refused() -> None:
    wire = Wire(mav.MAVLink_ridsafe_rid_frame_message, (-70.0, [0] * 20, 1, 6, 3, b"abc"))
    with pytest.raises(WireError, match="uint8"):
        wire_values(wire)


def test_reports_of_one_frame_encode_as_each_alone_whatever_their_signal_strength() -> None:
    """The payloads of a frame's reports share all but the signal strength
    (``wire._rid_frame_payload``): the same bytes as encoding each report afresh."""
    rng = random.Random(7)
    frames = [bytes([0x12]) + bytes(rng.randrange(256) for _ in range(24)), bytes([0x02]) * 25]
    strengths = [-71.25, -0.0, 0.0, 3.4e38, float("inf"), float("-inf"), 1e-45, -120.0]
    strengths += [rng.uniform(-110.0, -30.0) for _ in range(20)]
    for frame in frames:
        for sender in (b"", b"\x01\x02\x03\x04\x05\x06", b"RSAF800000002"):
            for rssi in strengths:
                report = m.RidFrameReport(frame, rssi, sender, int(m.RidTransport.SIMULATED))
                assert codec.encode_payload(report) == _encoded(report)
    nan = codec.encode_payload(m.RidFrameReport(frames[0], float("nan"), b"", 1))
    assert nan == _encoded(m.RidFrameReport(frames[0], float("nan"), b"", 1))
    too_strong = m.RidFrameReport(frames[0], 1e39, b"", 1)
    for encode in (codec.encode_payload, _encoded):  # refused alike
        with pytest.raises(OverflowError):
            encode(too_strong)
