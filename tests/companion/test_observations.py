"""RSSI pairing, the receiver's position at the receive time, observation reports and batching.

Oracles: for extrapolation, ``frames.ned_to_geodetic`` (the exact ECEF-based conversion)
against the radii-of-curvature formula; for pairing and batching, the list of what was sent
(every broadcast reported exactly once, or counted).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import cast

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import codec, f3411, frames, rid, topics
from ridsafe.common import messages as m
from ridsafe.companion.observations import (
    UNKNOWN_RID_TIMESTAMP_S,
    HeardBroadcast,
    ObservationBatcher,
    OwnTelemetry,
    ReceiverFix,
    RssiSource,
    SimTransponderRssi,
    batch_record,
    claimed_id,
    make_observation,
)
from ridsafe.sim_backend.transponder import Transponder

A, B = b"RSAF800000001", b"RSAF800000002"
LOC = int(m.OdidMessageType.LOCATION)


def _location(sender: bytes, timestamp_s: float = 12.0, lat: float = 36.1) -> m.OdidLocation:
    state = rid.OwnState(
        1_767_268_800.0 + timestamp_s, lat, -86.8, 230.0, 50.0, (3.0, 4.0, -1.0), True
    )
    return replace(rid.location(state), id_or_mac=sender)


def _rssi(sender: bytes, dbm: float, msg_type: int = LOC) -> m.RidRssi:
    return m.RidRssi(0.0, dbm, sender, msg_type)


def _source() -> SimTransponderRssi:
    return SimTransponderRssi(pair_timeout_s=0.5)


def test_the_sim_source_satisfies_the_interface() -> None:
    source: RssiSource = _source()
    assert source.name == "sim-transponder"


# --- pairing -------------------------------------------------------------------------------


def test_a_location_pairs_with_the_rssi_that_follows_it() -> None:
    source = _source()
    loc = _location(A)
    source.on_mavlink(1.0, loc)
    source.on_mavlink(1.0, _rssi(A, -70.5))
    assert source.poll(1.0) == [HeardBroadcast(loc, -70.5, 1.0)]
    assert source.counters()["paired"] == 1


def test_pairs_are_matched_by_id_when_two_senders_interleave() -> None:
    source = _source()
    la, lb = _location(A), _location(B)
    for msg in (la, lb, _rssi(B, -60.0), _rssi(A, -80.0)):
        source.on_mavlink(2.0, msg)
    got = {h.location.id_or_mac: h.rssi_dbm for h in source.poll(2.0)}
    assert got == {A: -80.0, B: -60.0}


def test_an_rssi_before_its_location_still_pairs_and_is_counted_out_of_order() -> None:
    source = _source()
    source.on_mavlink(3.0, _rssi(A, -65.0))
    loc = _location(A)
    source.on_mavlink(3.02, loc)
    assert source.poll(3.02) == [HeardBroadcast(loc, -65.0, 3.02)]
    assert source.counters()["out_of_order"] == 1


def test_a_location_without_rssi_is_handed_on_without_it_after_the_timeout() -> None:
    source = _source()
    loc = _location(A)
    source.on_mavlink(4.0, loc)
    assert source.poll(4.3) == []  # still waiting
    assert source.poll(4.6) == [HeardBroadcast(loc, None, 4.0)]
    assert source.counters()["location_without_rssi"] == 1


def test_an_rssi_without_location_is_dropped_and_counted() -> None:
    source = _source()
    source.on_mavlink(5.0, _rssi(A, -50.0))
    assert source.poll(5.6) == []
    source.on_mavlink(6.0, _location(A))  # the next second's LOCATION must not take it
    assert source.poll(6.7)[0].rssi_dbm is None
    counters = source.counters()
    assert counters["rssi_without_location"] == 1
    assert counters["location_without_rssi"] == 1


def test_rssi_of_other_message_types_and_other_odid_messages_are_counted_not_paired() -> None:
    source = _source()
    source.on_mavlink(1.0, rid.basic_id("RSAF800000002"))
    source.on_mavlink(1.0, _rssi(B, -60.0, int(m.OdidMessageType.BASIC_ID)))
    loc = _location(B)
    source.on_mavlink(1.0, loc)
    source.on_mavlink(1.0, _rssi(B, -61.0))
    assert source.poll(1.0) == [HeardBroadcast(loc, -61.0, 1.0)]
    counters = source.counters()
    assert counters["rssi_other_type"] == 1 and counters["other_odid"] == 1


def _heard_pack(sender: bytes, dbm: float, *messages: m.Message) -> list[m.Message]:
    """What a receiving transponder hands its companion for a message pack on the air."""
    frames = [f3411.encode(*codec.odid_fields(message)) for message in messages]
    return Transponder(9, b"RSAF800000009").receive(0.0, f3411.pack(frames), sender, dbm)


def test_a_location_in_a_message_pack_pairs_with_the_packs_rssi() -> None:
    source = _source()
    loc = _location(A)
    pack, rssi = _heard_pack(A, -72.0, rid.basic_id("RSAF800000001"), loc)
    assert rssi == _rssi(A, -72.0, int(m.OdidMessageType.MESSAGE_PACK))
    source.on_mavlink(1.0, pack)
    source.on_mavlink(1.0, rssi)
    (heard,) = source.poll(1.0)
    assert heard.rssi_dbm == -72.0 and heard.rx_t_s == 1.0
    assert heard.location.id_or_mac == A
    assert heard.location.lat_deg == pytest.approx(loc.lat_deg, abs=1e-7)
    assert source.counters()["paired"] == 1


def test_a_pack_without_location_neither_pairs_nor_takes_a_locations_rssi() -> None:
    source = _source()
    statics = _heard_pack(A, -72.0, rid.basic_id("RSAF800000001"), rid.operator_id("OP-1"))
    loc = _location(A)
    for message in [loc, *statics, _rssi(A, -70.0)]:
        source.on_mavlink(2.0, message)
    assert source.poll(2.0) == [HeardBroadcast(loc, -70.0, 2.0)]
    counters = source.counters()
    assert counters["other_odid"] == 1 and counters["rssi_other_type"] == 1
    assert counters["rssi_without_location"] == 0


@settings(max_examples=200, deadline=None)
@given(
    plan=st.lists(
        st.tuples(st.sampled_from([A, B]), st.booleans(), st.booleans(), st.booleans()),
        min_size=1,
        max_size=30,
    )
)
def test_every_location_comes_out_once_and_every_rssi_is_used_or_counted(
    plan: list[tuple[bytes, bool, bool, bool]],
) -> None:
    """Per broadcast (one per second): LOCATION and/or RSSI may be lost, and may swap order."""
    source = _source()
    out: list[HeardBroadcast] = []
    sent_locations = sent_rssi = 0
    for k, (sender, has_loc, has_rssi, swapped) in enumerate(plan):
        t = float(k)
        msgs: list[m.Message] = []
        if has_loc:
            msgs.append(_location(sender, timestamp_s=t))
            sent_locations += 1
        if has_rssi:
            msgs.append(_rssi(sender, -50.0 - k))
            sent_rssi += 1
        for msg in reversed(msgs) if swapped else msgs:
            source.on_mavlink(t, msg)
        out.extend(source.poll(t))
    out.extend(source.poll(len(plan) + 1.0))
    assert sorted(h.location.timestamp_s or 0.0 for h in out) == sorted(
        float(k) for k, p in enumerate(plan) if p[1]
    )
    assert len(out) == sent_locations
    c = source.counters()
    assert c["paired"] + c["location_without_rssi"] == sent_locations
    assert c["paired"] + c["rssi_without_location"] == sent_rssi
    for heard in out:  # a pair is always the same broadcast (same second)
        if heard.rssi_dbm is not None:
            assert heard.rssi_dbm == -50.0 - (heard.location.timestamp_s or 0.0)


# --- the receiver's position ------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(
    lat=st.floats(-80.0, 80.0),
    lon=st.floats(-180.0, 180.0),
    alt=st.floats(-100.0, 3000.0),
    v=st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0), st.floats(-5.0, 5.0)),
    dt=st.floats(-0.5, 0.5),
)
def test_extrapolation_matches_the_exact_ned_to_geodetic_conversion(
    lat: float, lon: float, alt: float, v: tuple[float, float, float], dt: float
) -> None:
    fix = ReceiverFix(10.0, lat, lon, alt, v)
    got = fix.at(10.0 + dt, max_extrapolation_s=1.0)
    origin = frames.GeodeticOrigin(lat, lon, alt)
    exact = frames.ned_to_geodetic(origin, np.array(v) * dt)
    back = frames.geodetic_to_ned(origin, *got)
    expected = frames.geodetic_to_ned(origin, *(float(x) for x in exact))
    assert np.linalg.norm(back - expected) < 1e-3


def test_extrapolation_is_bounded() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, -2.0))
    assert fix.at(100.0, max_extrapolation_s=1.0)[2] == 202.0
    assert fix.at(0.0, max_extrapolation_s=1.0) == (36.0, -86.0, 200.0)


# --- observations -----------------------------------------------------------------------------


def test_an_observation_carries_receiver_claim_rssi_and_time() -> None:
    loc = _location(A, timestamp_s=7.3)
    fix = ReceiverFix(9.9, 36.2, -86.7, 250.0, (1.0, 0.0, 0.0))
    obs = make_observation(HeardBroadcast(loc, -77.25, 10.0), fix, 10.5, 1.0)
    assert isinstance(obs, m.Observation)
    assert obs.t_s == 10.5
    assert obs.rx_lat_deg > 36.2 and obs.rx_lon_deg == -86.7 and obs.rx_alt_m == 250.0
    assert (obs.claimed_lat_deg, obs.claimed_lon_deg, obs.claimed_alt_m) == (36.1, -86.8, 230.0)
    assert obs.rid_timestamp_s == 7.3 and obs.rssi_dbm == -77.25
    assert obs.uas_id == "RSAF800000001"
    assert obs.claimed_speed_horizontal_m_s == 5.0 and obs.claimed_speed_vertical_m_s == 1.0


def test_observations_without_what_they_need_are_refused_with_a_reason() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    no_pos = replace(_location(A), lat_deg=None, lon_deg=None)
    assert make_observation(HeardBroadcast(_location(A), None, 0.0), fix, 0.0, 1.0) == "no_rssi"
    assert make_observation(HeardBroadcast(no_pos, -60.0, 0.0), fix, 0.0, 1.0) == (
        "no_claimed_position"
    )
    no_time = replace(_location(A), timestamp_s=None)
    obs = make_observation(HeardBroadcast(no_time, -60.0, 0.0), fix, 0.0, 1.0)
    assert isinstance(obs, m.Observation) and obs.rid_timestamp_s == UNKNOWN_RID_TIMESTAMP_S


def test_claimed_ids_are_printable_ascii() -> None:
    assert claimed_id(b"RSAF800000001") == "RSAF800000001"
    assert claimed_id(b"AB\x00\xffC") == "AB??C"
    assert len(claimed_id(bytes(range(40)))) == 20


@settings(max_examples=100, deadline=None)
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
            batcher.add(HeardBroadcast(_location(A, stamp), -60.0, t), fix, t, 1.0)
        batch = batcher.take_due(t)
        assert all(o.t_s > t - period - 1e-9 for o in batch)  # nothing waits over a period
        sent.extend(batch)
    sent.extend(batcher.take_all())
    expected = [round(rid.seconds_after_hour(1_767_268_800.0 + a), 1) for a in arrivals]
    assert sorted(o.rid_timestamp_s for o in sent) == sorted(expected)
    assert batcher.counters.reported == batcher.counters.heard == len(arrivals)


def test_a_batch_record_has_the_topics_fields() -> None:
    fix = ReceiverFix(0.0, 36.0, -86.0, 200.0, (0.0, 0.0, 0.0))
    obs = make_observation(HeardBroadcast(_location(A), -60.0, 0.0), fix, 0.0, 1.0)
    assert isinstance(obs, m.Observation)
    record = batch_record(4, [obs])
    assert set(topics.TOPICS[topics.OBSERVATIONS][1]) <= set(record)
    (item,) = cast(list[dict[str, float]], record["items"])
    assert math.isclose(item["rssi_dbm"], -60.0)


# --- own telemetry: clock, UNIX time, frames ---------------------------------------------------


def test_the_autopilot_clock_estimate_takes_the_least_delayed_sample_and_follows_a_reboot() -> None:
    own = OwnTelemetry()
    assert own.sim_time(3.0) == 3.0  # nothing heard yet
    own.observe_clock(10.0, 7.95)  # 50 ms on the way
    own.observe_clock(10.1, 8.09)  # 10 ms
    own.observe_clock(10.2, 8.13)  # 70 ms
    assert own.sim_time(11.0) == pytest.approx(8.99)
    own.observe_clock(20.0, 0.5)  # boot time restarted
    assert own.sim_time(21.0) == pytest.approx(1.5)


def test_unix_time_advances_from_system_time() -> None:
    own = OwnTelemetry()
    assert own.unix_s(1.0) is None
    own.system_time, own.system_time_s = m.SystemTime(1_767_268_800.0, 4.0), 4.02
    assert own.unix_s(6.52) == pytest.approx(1_767_268_802.5)
    own.system_time = m.SystemTime(0.0, 4.0)  # an autopilot without GPS time
    assert own.unix_s(6.52) is None


def test_local_frame_is_about_home_shifted_by_homes_local_position() -> None:
    own = OwnTelemetry()
    with pytest.raises(LookupError):
        own.to_local(36.0, -86.0, 200.0)
    # ArduPilot: LOCAL_POSITION_NED is about the EKF origin; home sits at (x, y, z) in it
    own.set_home(m.HomePosition(36.1447, -86.8027, 180.0, (12.0, -7.0, 1.5)))
    assert own.to_local(36.1447, -86.8027, 180.0) == pytest.approx((12.0, -7.0, 1.5))
    origin = frames.GeodeticOrigin(36.1447, -86.8027, 180.0)
    lat, lon, alt = frames.ned_to_geodetic(origin, np.array([300.0, -200.0, -50.0]))
    assert own.to_local(float(lat), float(lon), float(alt)) == pytest.approx(
        (312.0, -207.0, -48.5), abs=1e-6
    )
    back = own.to_geodetic((312.0, -207.0, -48.5))
    assert back == pytest.approx((float(lat), float(lon), float(alt)), abs=1e-9)
