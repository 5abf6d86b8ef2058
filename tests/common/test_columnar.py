"""A columnar link (the GCS's) decodes a run of RIDSAFE_OBSERVATION packets from one sender
at once: the same observations, in the same order, kept or dropped and counted exactly as a
link that decodes them one by one, whatever the bytes hold."""

from __future__ import annotations

import math
import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec
from ridsafe.common import messages as m
from ridsafe.common.codec import observation_kernels
from ridsafe.common.codec.wire import Payload
from ridsafe.common.dialect import ridsafe_v20 as mav

_OBSERVATION = mav.MAVLink_ridsafe_observation_message
_CRC_EXTRA = bytes([_OBSERVATION.crc_extra])
_KEY = bytes(range(32))

#: Wire values, valid or not: any int of each field's type, floats with NaN and inf, the
#: "unknown" sentinels and ids of any bytes (NULs, non-ASCII, control characters).
_f32 = st.floats(width=32) | st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -65.0])
_i32 = st.integers(-(2**31), 2**31 - 1) | st.integers(-1_800_000_000, 1_800_000_000)
_payload_fields = st.tuples(
    st.integers(0, 2**64 - 1) | st.integers(0, 5_000_000_000_000),  # time_usec
    _i32,
    _i32,
    _f32,
    _i32,
    _i32,
    _f32,
    _f32,
    _f32,
    st.integers(0, 2**16 - 1) | st.sampled_from([0, 35999, 36000, 36100]),
    st.integers(0, 2**16 - 1) | st.sampled_from([0, 25425, 25500]),
    st.integers(-(2**15), 2**15 - 1) | st.sampled_from([-6200, 0, 6300]),
    st.binary(max_size=20) | st.sampled_from([b"RSAF800000001", b"", b"\x00\x00", b"A\x00B"]),
)


def _plain_fields(index: int) -> tuple[object, ...]:
    """A valid observation's wire values (most packets of a real run)."""
    return (
        10_000_000 + index,
        361_447_000 + index,
        -868_027_000,
        200.0,
        361_450_000,
        -868_030_000 - index,
        210.0,
        1799.5,
        -70.0 - index,
        9000,
        500,
        -100,
        b"RSAF80000000%d" % (index % 10),
    )


def _packet(link: codec.MavlinkLink, fields: tuple[object, ...]) -> bytes:
    data = _OBSERVATION.unpacker.pack(*fields)
    return link.frame(Payload(_OBSERVATION.id, _CRC_EXTRA, data.rstrip(b"\x00") or data[:1]))


_PACK = mav.MAVLink_ridsafe_observation_pack_message
_PACK_STRUCT = struct.Struct("<3Q3i3i3f3i3i3f3f3f3H3H3hB60s")  # the uint8 ids as one item


def _pack_packet(link: codec.MavlinkLink, rows: list[tuple[object, ...]], count: int) -> bytes:
    """A RIDSAFE_OBSERVATION_PACK of ``rows`` (each RIDSAFE_OBSERVATION's wire values) that
    says it holds ``count``."""
    padded = rows + [(0,) * 12 + (b"",)] * (3 - len(rows))
    *columns, ids = zip(*padded, strict=True)
    id_bytes = b"".join(bytes(i)[:20].ljust(20, b"\x00") for i in ids)
    data = _PACK_STRUCT.pack(*(v for column in columns for v in column), count, id_bytes)
    extra = bytes([_PACK.crc_extra])
    return link.frame(Payload(_PACK.id, extra, data.rstrip(b"\x00") or data[:1]))


def _as_rows(received: list[codec.Received]) -> list[tuple[int, int, bool, m.Message]]:
    """Every message, rows expanded to the observations they hold."""
    out: list[tuple[int, int, bool, m.Message]] = []
    for r in received:
        if isinstance(r.message, m.ObservationRows):
            rows = r.message
            sender = (r.src_system, r.src_component, r.signed)
            out += [(*sender, rows.observation(i)) for i in range(len(rows))]
        else:
            out.append((r.src_system, r.src_component, r.signed, r.message))
    return out


def _count(message: m.Message) -> int:
    return len(message) if isinstance(message, m.ObservationRows) else 1


def _same(a: object, b: object) -> bool:
    """Equal, NaN equal to NaN (a dropped row never gets here, but be exact)."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


@settings(max_examples=300)
@given(
    packets=st.lists(
        st.tuples(
            st.sampled_from(["plain", "raw", "heartbeat", "pack", "raw pack", "count"]),
            _payload_fields,
            st.sets(st.integers(0, 12), min_size=1, max_size=3),
            st.integers(1, 3),
        ),
        min_size=1,
        max_size=24,
    ),
    signed=st.booleans(),
)
def test_a_columnar_link_keeps_drops_and_counts_as_one_that_decodes_one_by_one(
    packets: list[tuple[str, tuple[object, ...], set[int], int]], signed: bool
) -> None:
    """``raw`` packets are a valid one with one to three fields replaced by any wire value;
    ``pack``: a RIDSAFE_OBSERVATION_PACK of one to three valid reports, ``raw pack`` with the
    first of them raw, ``count`` with a count of 0 to 4 whatever it holds."""
    signing = codec.SigningConfig(_KEY, 1000) if signed else None
    senders = {sysid: codec.MavlinkLink(sysid, 191, signing) for sysid in (1, 2, 3)}
    datagram = b""
    for index, (kind, fields, replaced, sysid) in enumerate(packets):
        sender = senders[sysid]
        if kind == "heartbeat":
            datagram += sender.pack(m.Heartbeat(18, 8, 0, 0, 4))
            continue
        values = _plain_fields(index)
        if kind in ("raw", "raw pack"):
            values = tuple(fields[k] if k in replaced else v for k, v in enumerate(values))
        if kind in ("pack", "raw pack", "count"):
            rows = [values] + [_plain_fields(index + 100 + j) for j in range(len(replaced) - 1)]
            count = len(rows) if kind != "count" else int(fields[0]) % 5  # type: ignore[call-overload]
            datagram += _pack_packet(sender, rows, count)
        else:
            datagram += _packet(sender, values)
    by_rows = codec.MavlinkLink(255, 190, signing and codec.SigningConfig(_KEY, 0), columnar=True)
    one_by_one = codec.MavlinkLink(255, 190, signing and codec.SigningConfig(_KEY, 0))
    got, expected = _as_rows(by_rows.feed(datagram)), _as_rows(one_by_one.feed(datagram))
    assert len(got) == len(expected)
    for (*ids_a, a), (*ids_b, b) in zip(got, expected, strict=True):
        assert ids_a == ids_b and type(a) is type(b)
        if isinstance(a, m.Observation) and isinstance(b, m.Observation):
            for name in a.__dataclass_fields__:
                assert _same(getattr(a, name), getattr(b, name)), name
        else:
            assert a == b
    assert by_rows.counters == one_by_one.counters


def test_a_run_of_one_sender_comes_as_one_received_of_its_rows() -> None:
    a, b = codec.MavlinkLink(4, 191), codec.MavlinkLink(5, 191)
    datagram = b"".join(_packet(a, _plain_fields(i)) for i in range(5))
    datagram += a.pack(m.Heartbeat(18, 8, 0, 0, 4))
    datagram += b"".join(_packet(a, _plain_fields(i)) for i in range(2))
    datagram += b"".join(_packet(b, _plain_fields(i)) for i in range(3))
    link = codec.MavlinkLink(255, 190, columnar=True)
    received = link.feed(datagram)
    kinds = [(r.src_system, type(r.message).__name__, _count(r.message)) for r in received]
    assert kinds == [
        (4, "ObservationRows", 5),
        (4, "Heartbeat", 1),
        (4, "ObservationRows", 2),
        (5, "ObservationRows", 3),
    ]
    assert link.counters.accepted == 11
    rows = received[0].message
    assert isinstance(rows, m.ObservationRows) and not rows.values.flags.writeable
    assert rows.observation(2).rssi_dbm == -72.0 and rows.uas_id[2] == "RSAF800000002"


def test_one_bad_row_sends_its_run_one_by_one_and_is_named() -> None:
    a = codec.MavlinkLink(4, 191)
    bad = list(_plain_fields(1))
    bad[1] = 950_000_000  # latitude 95 deg
    datagram = _packet(a, _plain_fields(0)) + _packet(a, tuple(bad)) + _packet(a, _plain_fields(2))
    link = codec.MavlinkLink(255, 190, columnar=True)
    received = link.feed(datagram)
    assert [type(r.message) for r in received] == [m.Observation, m.Observation]
    assert link.counters.accepted == 2 and link.counters.invalid_value == 1
    assert link.counters.invalid_fields == {"RIDSAFE_OBSERVATION.decode": 1}


def test_a_pack_decodes_to_its_reports_in_order_and_a_bad_one_refuses_the_pack() -> None:
    a = codec.MavlinkLink(4, 191)
    reports = [_plain_fields(i) for i in range(5)]
    bad = list(_plain_fields(9))
    bad[3] = math.nan  # receiver altitude
    datagram = _pack_packet(a, reports[:3], 3) + _pack_packet(a, reports[3:], 2)
    datagram += _pack_packet(a, [reports[0], tuple(bad)], 2)
    for columnar in (True, False):
        link = codec.MavlinkLink(255, 190, columnar=columnar)
        rows = [o for r in link.feed(datagram) for o in _rows_of(r.message)]
        assert [o.rssi_dbm for o in rows] == [-70.0 - i for i in range(5)]
        assert link.counters.accepted == 2 and link.counters.invalid_value == 1


def _rows_of(message: m.Message) -> list[m.Observation]:
    assert isinstance(message, m.ObservationRows)
    return message.observations()


def test_the_kernels_field_offsets_are_the_wire_layout() -> None:
    """``ridsafe_messages`` checks this at import; here it is checked against pymavlink's
    own packing, field by field."""
    fields = list(_plain_fields(3))
    packed = _OBSERVATION.unpacker.pack(*fields)
    for name, value in zip(_OBSERVATION.ordered_fieldnames, fields, strict=True):
        offset = observation_kernels.OFFSETS[name]
        if isinstance(value, bytes):
            assert packed[offset : offset + len(value)] == value
        else:
            code = _OBSERVATION.unpacker.format[1:]
            index = _OBSERVATION.ordered_fieldnames.index(name)
            (got,) = struct.unpack_from("<" + code[index], packed, offset)
            assert got == value
