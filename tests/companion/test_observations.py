"""Heard frames -> observation reports: the RSSI that came with a frame is the one reported,
LOCATIONs in packs, what cannot be reported is counted, batching.

Oracle: the list of what was sent (every LOCATION heard reported exactly once, or counted).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import cast

from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec, f3411, rid, topics
from ridsafe.common import messages as m
from ridsafe.common.heard import (
    HeardRidFrame,
    LocationClaim,
    RidFrameDecoder,
    claim_of,
    claimed_id,
)
from ridsafe.common.logsink import MemorySink
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.observations import (
    MAX_PENDING_OBSERVATIONS,
    UNKNOWN_RID_TIMESTAMP_S,
    ObservationBatcher,
    ObservationReporter,
    batch_record,
    observation_row,
)
from ridsafe.companion.telemetry import OwnTelemetry, ReceiverFix

A, B = b"RSAF800000001", b"RSAF800000002"
SIM = int(m.RidTransport.SIMULATED)


def _location(sender: bytes, timestamp_s: float = 12.0, lat: float = 36.1) -> m.OdidLocation:
    state = rid.OwnState(
        1_767_268_800.0 + timestamp_s, lat, -86.8, 230.0, 50.0, (3.0, 4.0, -1.0), True
    )
    return replace(rid.location(state), id_or_mac=sender)


def _frame(message: m.Message) -> bytes:
    return f3411.encode(*codec.odid_fields(message))


def _heard(t_s: float, frame: bytes, dbm: float, sender: bytes = A) -> HeardRidFrame:
    return HeardRidFrame(t_s, m.RidFrameReport(frame, dbm, sender, SIM))


def _own() -> OwnTelemetry:
    own = OwnTelemetry()
    own.gpi = m.GlobalPositionInt(0.0, 36.0, -86.0, 200.0, 20.0, (0.0, 0.0, 0.0), None)
    return own


class _Sent:
    """What the reporter sends: its batches (``ObservationRows``), unpacked."""

    def __init__(self) -> None:
        self.observations: list[m.Observation] = []
        self.batches = 0

    def __call__(self, messages: list[m.Message]) -> None:
        for message in messages:
            assert isinstance(message, m.ObservationRows) and len(message) >= 1
            self.observations.extend(message.observations())
            self.batches += 1


def _report(claim: LocationClaim, rssi_dbm: float, rx: m.Vec3, t_s: float) -> m.Observation:
    """The report ``observation_row`` makes, as the ``Observation`` it goes as."""
    row = observation_row(claim, rssi_dbm, rx, t_s)
    assert not isinstance(row, str)
    return m.ObservationRows.of_rows([row], [claim.uas_id]).observation(0)


def _reporter(period_s: float = 0.25) -> ObservationReporter:
    return ObservationReporter(1, period_s, 1.0, NeighbourTable("RSAF800000003"))


# --- the reporter: frames in, observations out -----------------------------------------------


def test_each_frame_is_reported_with_its_own_rssi_without_pairing() -> None:
    """Two senders heard in one step: each observation carries the RSSI of its own frame."""
    reporter, sent, sink = _reporter(), _Sent(), MemorySink()
    reporter.hear(
        [
            _heard(1.0, _frame(_location(A)), -80.0, A),
            _heard(1.0, _frame(_location(B, lat=36.2)), -60.0, B),
        ]
    )
    reporter.report(1.0, _own(), True, sent, sink)
    got = {o.uas_id: o.rssi_dbm for o in sent.observations}
    assert got == {"RSAF800000001": -80.0, "RSAF800000002": -60.0}
    assert len(reporter.neighbours) == 2
    assert [name for name, _, _ in sink.records] == [topics.OBSERVATIONS]


def test_a_location_in_a_message_pack_is_reported_with_the_packs_rssi() -> None:
    reporter, sent = _reporter(), _Sent()
    loc = _location(A)
    pack = f3411.pack([_frame(rid.basic_id("RSAF800000001")), _frame(loc)])
    reporter.hear([_heard(2.0, pack, -72.0)])
    reporter.report(2.0, _own(), True, sent, MemorySink())
    (obs,) = sent.observations
    assert obs.rssi_dbm == -72.0 and obs.uas_id == "RSAF800000001"
    assert math.isclose(obs.claimed_lat_deg, loc.lat_deg or 0.0, abs_tol=1e-7)


def test_frames_without_location_and_unreadable_frames_are_counted_not_reported() -> None:
    reporter, sent = _reporter(), _Sent()
    statics = f3411.pack([_frame(rid.basic_id("RSAF800000001")), _frame(rid.operator_id("OP"))])
    reporter.hear([_heard(1.0, statics, -70.0), _heard(1.0, b"\x7f" + bytes(24), -70.0)])
    reporter.report(1.0, _own(), True, sent, MemorySink())
    c = reporter.counters
    assert sent.observations == []
    assert (c.frames, c.frame_errors, c.frames_without_location, c.heard) == (2, 1, 2, 0)


def test_without_an_own_position_nothing_is_reported_and_it_is_counted() -> None:
    reporter, sent = _reporter(), _Sent()
    reporter.hear([_heard(1.0, _frame(_location(A)), -70.0)])
    reporter.report(1.0, OwnTelemetry(), True, sent, MemorySink())
    assert sent.observations == [] and reporter.counters.no_own_position == 1


def test_observations_sent_before_the_gcs_was_heard_are_counted() -> None:
    reporter, sent = _reporter(), _Sent()
    reporter.hear([_heard(1.0, _frame(_location(A)), -70.0)])
    reporter.report(1.0, _own(), False, sent, MemorySink())
    assert len(sent.observations) == 1 and reporter.counters.sent_before_gcs_seen == 1


def test_a_shared_decoder_decodes_a_broadcast_once_for_every_receiver() -> None:
    decoder = RidFrameDecoder()
    frame = _frame(_location(A))
    reporters = [
        ObservationReporter(k, 0.25, 1.0, NeighbourTable(f"RSAF80000001{k}"), decoder)
        for k in range(3)
    ]
    for k, reporter in enumerate(reporters):
        reporter.hear([_heard(1.0, frame, -60.0 - k)])
        sent = _Sent()
        reporter.report(1.0, _own(), True, sent, MemorySink())
        assert [o.rssi_dbm for o in sent.observations] == [-60.0 - k]
    assert decoder.decode(frame, A) is decoder.decode(frame, A)


# --- one observation ------------------------------------------------------------------------


def test_an_observation_carries_receiver_claim_rssi_and_time() -> None:
    loc = _location(A, timestamp_s=7.3)
    fix = ReceiverFix(9.9, 36.2, -86.7, 250.0, (1.0, 0.0, 0.0))
    heard = _heard(10.0, b"", -77.25)
    obs = _report(claim_of(loc), heard.rssi_dbm, fix.at(heard.rx_t_s, 1.0), 10.5)
    assert obs.t_s == 10.5
    assert obs.rx_lat_deg > 36.2 and obs.rx_lon_deg == -86.7 and obs.rx_alt_m == 250.0
    assert (obs.claimed_lat_deg, obs.claimed_lon_deg, obs.claimed_alt_m) == (36.1, -86.8, 230.0)
    assert obs.rid_timestamp_s == 7.3 and obs.rssi_dbm == -77.25
    assert obs.uas_id == "RSAF800000001"
    assert obs.claimed_speed_horizontal_m_s == 5.0 and obs.claimed_speed_vertical_m_s == 1.0


def test_observations_without_what_they_need_are_refused_with_a_reason() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    no_pos = replace(_location(A), lat_deg=None, lon_deg=None)
    assert observation_row(claim_of(no_pos), -60.0, fix.at(0.0, 1.0), 0.0) == "no_claimed_position"
    no_time = replace(_location(A), timestamp_s=None)
    obs = _report(claim_of(no_time), -60.0, fix.at(0.0, 1.0), 0.0)
    assert obs.rid_timestamp_s == UNKNOWN_RID_TIMESTAMP_S
    unknown = replace(_location(A), course_deg=None, speed_horizontal_m_s=None)
    obs = _report(claim_of(unknown), -60.0, fix.at(0.0, 1.0), 0.0)
    assert obs.claimed_course_deg is None and obs.claimed_speed_horizontal_m_s is None
    assert obs.claimed_speed_vertical_m_s == 1.0


def test_claimed_ids_are_printable_ascii() -> None:
    assert claimed_id(b"RSAF800000001") == "RSAF800000001"
    assert claimed_id(b"AB\x00\xffC") == "AB??C"
    assert len(claimed_id(bytes(range(40)))) == 20


@settings(max_examples=100)
@given(arrivals=st.lists(st.floats(0.0, 10.0), max_size=60), period=st.sampled_from([0.1, 0.25]))
def test_batching_reports_every_heard_broadcast_exactly_once(
    arrivals: list[float], period: float
) -> None:
    batcher = ObservationBatcher(period)
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    pending = sorted(arrivals)
    sent: list[m.Observation] = []
    for k in range(0, 1101):
        t = k * 0.01
        while pending and pending[0] <= t:
            stamp = pending.pop(0)
            batcher.add(claim_of(_location(A, stamp)), -60.0, fix.at(t, 1.0), t)
        batch = batcher.take_due(t)
        reports = [] if batch is None else batch.observations()
        assert all(o.t_s > t - period - 1e-9 for o in reports)  # nothing waits over a period
        sent.extend(reports)
    rest = batcher.take_all()
    sent.extend([] if rest is None else rest.observations())
    expected = [round(rid.seconds_after_hour(1_767_268_800.0 + a), 1) for a in arrivals]
    assert sorted(o.rid_timestamp_s for o in sent) == sorted(expected)
    assert batcher.counters.reported == batcher.counters.heard == len(arrivals)


def test_a_batch_record_has_the_topics_fields() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    record = batch_record(4, m.ObservationRows.of([_report(claim_of(_location(A)), -60.0,
                                                           fix.at(0.0, 1.0), 0.0)]))  # fmt: skip
    assert set(topics.TOPICS[topics.OBSERVATIONS][1]) <= set(record)
    (item,) = cast(list[dict[str, float]], record["items"])
    assert math.isclose(item["rssi_dbm"], -60.0)


def test_a_flood_of_broadcasts_fills_one_batch_to_its_limit_and_counts_the_rest() -> None:
    batcher = ObservationBatcher(0.5)
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    extra = 25
    for _ in range(MAX_PENDING_OBSERVATIONS + extra):  # all at one instant: no batch is due
        batcher.add(claim_of(_location(A)), -60.0, fix.at(1.0, 1.0), 1.0)
    assert batcher.counters.batch_full == extra
    full = batcher.take_all()
    assert full is not None and len(full) == MAX_PENDING_OBSERVATIONS
    batcher.add(claim_of(_location(A)), -60.0, fix.at(1.0, 1.0), 1.0)  # room again
    again = batcher.take_all()
    assert batcher.counters.batch_full == extra and again is not None and len(again) == 1
    assert batcher.take_all() is None
