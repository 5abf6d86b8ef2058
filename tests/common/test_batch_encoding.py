"""Messages encoded and framed many at a time, to the bytes one at a time gives: a companion's
batch of reports, sent as observation packs (``codec.encode_payloads``), and the sim's RID
frame reports (``MavlinkLink.frame_rid_reports``)."""

from __future__ import annotations

import math
import random
import struct
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.errors import WireError


def _round_trip(message: m.Message) -> m.Message:
    (received,) = codec.MavlinkLink(255, 190).feed(codec.MavlinkLink(1, 1).pack(message))
    return received.message


#: Any float a report could hold: ordinary values, ties of the roundings, values beyond
#: their fields, NaN and infinities.
_any_float = st.one_of(
    st.floats(-200.0, 200.0),
    st.sampled_from([0.5, 2.5, -0.5, 5e-8, 1.5e-7, 0.005, 359.995, -0.005, 254.255, 3.4028235e38]),
    st.floats(allow_nan=True, allow_infinity=True),
)
_report = st.builds(
    m.Observation,
    *[_any_float] * 9,
    *[st.none() | _any_float] * 3,
    uas_id=st.sampled_from(["RSAF800000001", "", "A" * 20, "A" * 21, "\u00e9"]),
)


def _each_encoded(packs: list[m.ObservationPack]) -> list[codec.Payload] | None:
    try:
        return [codec.encode_payload(pack) for pack in packs]
    except (WireError, struct.error, ValueError, OverflowError):
        return None


@settings(max_examples=400)
@given(reports=st.lists(_report, min_size=1, max_size=10))
def test_a_batch_encodes_to_the_bytes_of_each_of_its_packs_encoded_alone(
    reports: list[m.Observation],
) -> None:
    """``encode_payloads``' compiled pass over a batch: the bytes ``encode_payload`` gives its
    packs (three reports to a pack, ``codec.pack_rows``) one by one, and an error where that
    raises one."""
    batch = m.ObservationRows.of(reports)
    packs = codec.pack_rows(batch)
    in_packs = [o for pack in packs for o in pack.observations]
    assert repr(in_packs) == repr(batch.observations())  # NaN as NaN
    assert [len(pack.observations) for pack in packs[:-1]] == [3] * (len(packs) - 1)
    alone = _each_encoded(packs)
    if alone is None:
        with pytest.raises((WireError, struct.error, ValueError, OverflowError)):
            codec.encode_payloads([batch])
    else:
        assert codec.encode_payloads([batch]) == alone


def test_a_batch_of_ordinary_reports_takes_the_compiled_pass() -> None:
    """So the equality above is the compiled pass's, not the fallback's with itself."""
    rng = random.Random(5)
    reports = [
        m.Observation(rng.uniform(0, 120), 36.1, -86.8, 230.0 + k, 36.1, -86.8, 240.0, 1799.5,
                      rng.uniform(-95, -40), rng.choice([None, 359.996, 12.345]), 5.0, -1.0,
                      f"RSAF8000000{k:02d}")
        for k in range(7)
    ]  # fmt: skip
    batch = m.ObservationRows.of(reports)
    payloads = codec.observation_rows_payloads(batch)
    assert payloads is not None
    assert payloads == [codec.encode_payload(pack).data for pack in codec.pack_rows(batch)]


def test_a_report_with_a_course_or_speed_not_finite_goes_with_them_unknown() -> None:
    report = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, math.nan, math.inf, -math.inf, "A"
    )
    unknown = m.Observation(
        1.0, 36.1, -86.8, 200.0, 36.1, -86.8, 210.0, 1.0, -70.0, None, None, None, "A"
    )
    assert _round_trip(report) == _round_trip(unknown)
    assert codec.encode_payloads([m.ObservationRows.of([report])]) == [
        codec.encode_payload(m.ObservationPack((unknown,)))
    ]


# --- the sim's RID frame reports ---------------------------------------------------------------

_frame = st.binary(min_size=1, max_size=228).map(
    lambda b: b if b[-1] else b[:-1] + b"\x07"
) | st.sampled_from([b"\x12" + bytes(24), b"\x01", b"\x12\x00\x00"])
_rid_report = st.builds(
    m.RidFrameReport,
    _frame,
    st.just(0.0),
    st.binary(max_size=20),
    st.sampled_from([0, 1, 2, 3]),
    st.sampled_from([0, 6]),
)


@settings(max_examples=300)
@given(
    frames=st.lists(_rid_report, min_size=1, max_size=6),
    heard=st.lists(
        st.tuples(
            st.integers(0, 2),  # which link
            st.integers(0, 5),  # which frame
            st.one_of(st.floats(-120.0, 20.0), st.sampled_from([0.0, -0.0, -64.0, 1e-45, 3e38])),
        ),
        max_size=30,
    ),
    first_seqs=st.lists(st.integers(0, 255), min_size=3, max_size=3),
)
def test_rid_frame_reports_framed_together_are_the_packets_of_each_packed_alone(
    frames: list[m.RidFrameReport], heard: list[tuple[int, int, float]], first_seqs: list[int]
) -> None:
    """Per link: header, sequence numbers (wrapping), trimmed payload and CRC, byte for byte;
    each link's sequence number advanced as by packing one by one."""
    heard = sorted(heard, key=lambda h: h[0])  # grouped by link
    together = [codec.MavlinkLink(7 + k, 236) for k in range(3)]
    alone = [codec.MavlinkLink(7 + k, 236) for k in range(3)]
    for k, seq in enumerate(first_seqs):
        together[k]._seq = alone[k]._seq = seq
    counts = [sum(1 for h in heard if h[0] == k) for k in range(3)]
    tail_of = np.array([f % len(frames) for _, f, _ in heard], dtype=np.int64)
    rssi_dbm = np.array([r for _, _, r in heard], dtype=np.float64)
    got = codec.frame_rid_reports(
        together, counts, codec.RidFrameTails.of(frames), tail_of, rssi_dbm
    )
    want: list[list[bytes]] = [[], [], []]
    for (k, _, r), f in zip(heard, tail_of.tolist(), strict=True):
        want[k].append(alone[k].pack(replace(frames[f], rssi_dbm=r)))
    assert got == want
    assert [link._seq for link in together] == [link._seq for link in alone]


def test_a_signed_link_or_a_strength_beyond_float32_frames_none() -> None:
    """The caller then sends the reports as messages (signatures, ``struct``'s error)."""
    tails = codec.RidFrameTails.of([m.RidFrameReport(b"\x12" + bytes(24), 0.0, b"A", 3)])
    signed = codec.MavlinkLink(1, 236, codec.SigningConfig(bytes(range(32)), 0))
    plain = codec.MavlinkLink(2, 236)
    one = np.zeros(1, dtype=np.int64)
    assert codec.frame_rid_reports([plain, signed], [1, 0], tails, one, np.array([-70.0])) is None
    for rssi in (1e39, math.inf, math.nan):
        assert codec.frame_rid_reports([plain], [1], tails, one, np.array([rssi])) is None
    assert plain._seq == 0
    assert codec.frame_rid_reports([plain], [0], tails, np.zeros(0, np.int64), np.zeros(0)) == [[]]
