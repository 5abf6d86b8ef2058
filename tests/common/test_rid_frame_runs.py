"""A columnar link (a companion's autopilot link) takes a run of RIDSAFE_RID_FRAME packets
from one sender as one ``RidFrameReports``: the same reports, in the same order, kept or
dropped and counted exactly as a link that decodes them one by one, whatever the strengths
hold and whether their frames were decoded before."""

from __future__ import annotations

import math
import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.codec.wire import Payload
from ridsafe.common.dialect import ridsafe_v20 as mav

_RID_FRAME = mav.MAVLink_ridsafe_rid_frame_message
_FRAMES = [bytes([0x12, k]) + bytes(range(k, k + 23)) for k in range(4)]


def _report_packet(sender: codec.MavlinkLink, frame: bytes, rssi_dbm: float) -> bytes:
    """A RIDSAFE_RID_FRAME packet of ``frame`` with any float32 strength (NaN and infinities
    too, which no valid sender sends)."""
    good = codec.encode_payload(m.RidFrameReport(frame, -1.0, b"RSAF800000001", 3)).data
    data = struct.pack("<f", rssi_dbm) + good[4:]
    return sender.frame(Payload(_RID_FRAME.id, bytes([_RID_FRAME.crc_extra]), data))


def _flat(received: list[codec.Received]) -> list[tuple[int, int, object]]:
    out: list[tuple[int, int, object]] = []
    for item in received:
        messages = (
            item.message.reports if isinstance(item.message, m.RidFrameReports) else (item.message,)
        )
        out += [(item.src_system, item.src_component, message) for message in messages]
    return out


@settings(max_examples=200)
@given(
    packets=st.lists(
        st.tuples(
            st.sampled_from(["report", "heartbeat"]),
            st.integers(0, 3),  # which frame
            st.floats(width=32) | st.sampled_from([math.nan, math.inf, -64.0]),
            st.integers(1, 2),  # which sender
        ),
        min_size=1,
        max_size=30,
    ),
    repeats=st.integers(1, 3),
)
def test_a_run_of_rid_frames_keeps_drops_and_counts_as_one_by_one(
    packets: list[tuple[str, int, float, int]], repeats: int
) -> None:
    """Fed ``repeats`` times: the first time some frames are new to the process (decoded
    whole, one by one), then they are known (decoded together)."""
    senders = {sysid: codec.MavlinkLink(sysid, 236) for sysid in (1, 2)}
    by_runs, one_by_one = codec.MavlinkLink(9, 191, columnar=True), codec.MavlinkLink(9, 191)
    for _ in range(repeats):
        datagram = b""
        for kind, frame, rssi_dbm, sysid in packets:
            if kind == "heartbeat":
                datagram += senders[sysid].pack(m.Heartbeat(18, 8, 0, 0, 4))
            else:
                datagram += _report_packet(senders[sysid], _FRAMES[frame], rssi_dbm)
        got, expected = _flat(by_runs.feed(datagram)), _flat(one_by_one.feed(datagram))
        assert got == expected
    assert by_runs.counters == one_by_one.counters


def test_a_datagram_of_known_frames_comes_as_one_received() -> None:
    sender = codec.MavlinkLink(1, 236)
    datagram = b"".join(_report_packet(sender, frame, -70.0 - k) for k, frame in enumerate(_FRAMES))
    link = codec.MavlinkLink(9, 191, columnar=True)
    link.feed(datagram)  # the frames decoded whole once (this process remembers them)
    (received,) = link.feed(datagram)
    assert isinstance(received.message, m.RidFrameReports)
    assert [r.rssi_dbm for r in received.message.reports] == [-70.0, -71.0, -72.0, -73.0]
    assert [r.frame for r in received.message.reports] == _FRAMES
    assert link.counters.accepted == 8
    # counted as the four messages it stands for where a core refuses or ignores it
    assert m.messages_in(received.message) == 4
    assert m.messages_in(m.Heartbeat(18, 8, 0, 0, 4)) == 1
