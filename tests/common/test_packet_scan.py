"""A datagram of whole, known packets with right CRCs is cut and checked in one compiled call
(``frame_kernels.scan_packets``) before ``MavlinkLink.feed`` decodes its packets; anything
else is left to the byte-by-byte parser. Either way a link keeps, drops and counts the same:
the same messages in the same order, the same counters, whatever the bytes hold."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.codec import link as link_module
from ridsafe.common.codec.frame_kernels import NOT_PLAIN, scan_packets

_KEY = bytes(range(32))
_SIM = int(m.RidTransport.SIMULATED)
_OBS = m.Observation(1.0, 36.0, -86.0, 200.0, 36.1, -86.1, 210.0, 5.0, -70.0, 10.0, 3.0, 0.0, "A")


def _message(kind: str, index: int) -> m.Message:
    if kind == "heartbeat":
        return m.Heartbeat(18, 8, 0, 0, 4)
    if kind == "pack":
        return m.ObservationPack((_OBS,) * (1 + index % 3))
    return m.RidFrameReport(bytes([0x12]) + bytes([index % 256]) * 24, -60.0 - index, b"S", _SIM)


def _scan(datagram: bytes) -> int | list[int]:
    ends = np.empty(len(datagram) // 12, dtype=np.int64)
    count = scan_packets(np.frombuffer(datagram, np.uint8), link_module._CRC_EXTRA_BY_ID, ends)
    return count if count == NOT_PLAIN else ends[:count].tolist()


def _taken(received: list[codec.Received]) -> list[tuple[object, ...]]:
    """What a link handed over, comparable: rows as their messages, NaN as a string."""
    out: list[tuple[object, ...]] = []
    for r in received:
        message = r.message
        if isinstance(message, m.ObservationRows):
            items: list[object] = [repr(message.observation(i)) for i in range(len(message))]
        elif isinstance(message, m.RidFrameReports):
            items = list(message.reports)
        else:
            items = [message]
        out += [(r.src_system, r.src_component, r.signed, item) for item in items]
    return out


def test_a_plain_datagram_is_cut_at_each_packet_end() -> None:
    unsigned = codec.MavlinkLink(1, 1)
    signed = codec.MavlinkLink(2, 1, codec.SigningConfig(_KEY, 1000))
    packets = [link.pack(_message(kind, k)) for k, (link, kind) in enumerate(
        [(unsigned, "heartbeat"), (signed, "pack"), (unsigned, "rid"), (signed, "rid")]
    )]  # fmt: skip
    datagram = b"".join(packets)
    assert _scan(datagram) == np.cumsum([len(p) for p in packets]).tolist()
    assert _scan(b"") == []


@pytest.mark.parametrize(
    "spoil",
    [
        pytest.param(lambda d: d[:-1], id="a partial packet"),
        pytest.param(lambda d: d + b"\x00", id="a byte after the last packet"),
        pytest.param(lambda d: b"garbage" + d, id="garbage first"),
        pytest.param(lambda d: d[:12] + bytes([d[12] ^ 0x01]) + d[13:], id="a payload bit"),
        pytest.param(lambda d: d[:2] + b"\x02" + d[3:], id="an unknown incompat flag"),
        pytest.param(lambda d: d[:7] + b"\xff\xff\x00" + d[10:], id="an unknown message id"),
        pytest.param(lambda d: d[:7] + b"\x00\x00\x01" + d[10:], id="an id beyond the table"),
    ],
)
def test_anything_but_whole_known_packets_with_right_crcs_is_left_to_the_parser(
    spoil: object,
) -> None:
    link = codec.MavlinkLink(1, 1)
    datagram = b"".join(link.pack(_message("rid", k)) for k in range(3))
    assert callable(spoil)
    assert _scan(spoil(datagram)) == NOT_PLAIN


_parts = st.lists(
    st.tuples(st.sampled_from(["heartbeat", "pack", "rid"]), st.integers(1, 3), st.booleans()),
    min_size=1,
    max_size=12,
)
_spoils = st.lists(
    st.tuples(st.sampled_from(["flip", "cut", "insert", "none"]), st.integers(0, 10_000)),
    max_size=3,
)


@settings(max_examples=300, deadline=None)
@given(parts=_parts, spoils=_spoils, columnar=st.booleans(), keyed=st.booleans())
def test_a_link_takes_a_datagram_alike_scanned_or_parsed_byte_by_byte(
    parts: list[tuple[str, int, bool]],
    spoils: list[tuple[str, int]],
    columnar: bool,
    keyed: bool,
) -> None:
    """Packets of three senders, signed or not, then bytes flipped, cut off or inserted: the
    link that scans and the one that parses every datagram byte by byte (the scan's size
    threshold out of reach) hand over and count the same."""
    signing = codec.SigningConfig(_KEY, 1000)
    senders = {
        (sysid, sign): codec.MavlinkLink(sysid, 191, signing if sign else None)
        for sysid in (1, 2, 3)
        for sign in (False, True)
    }
    datagram = b"".join(
        senders[sysid, sign].pack(_message(kind, k)) for k, (kind, sysid, sign) in enumerate(parts)
    )
    for what, drawn in spoils:
        at = drawn % (len(datagram) + 1)
        if what == "flip" and at < len(datagram):
            datagram = datagram[:at] + bytes([datagram[at] ^ (1 + at % 255)]) + datagram[at + 1 :]
        elif what == "cut":
            datagram = datagram[:at]
        elif what == "insert":
            datagram = datagram[:at] + bytes([0xFD, at % 256]) + datagram[at:]
    receiver = codec.SigningConfig(_KEY, 0) if keyed else None
    scanning = codec.MavlinkLink(255, 190, receiver, columnar=columnar)
    parsing = codec.MavlinkLink(255, 190, receiver, columnar=columnar)
    scanned = _taken(scanning.feed(datagram))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(link_module, "_SCAN_FROM_BYTES", math.inf)
        parsed = _taken(parsing.feed(datagram))
    assert scanned == parsed
    assert scanning.counters == parsing.counters
