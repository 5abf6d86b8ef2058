"""Ingest: validation per reason (counted, never raised), grouping by transmission over several
ticks, duplicates and late receptions, bounded history.

Oracle for positions: reports are built from known ENU points through
``frames.enu_to_geodetic``; the ingest must give the same ENU points back.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common import frames
from ridsafe.common.errors import FieldValueError
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.messages import Observation, ObservationRows
from ridsafe.gcs.config import GcsConfig
from ridsafe.gcs.ingest import (
    Ingest,
    RateLimitedLog,
    RejectReason,
    claimed_velocity_enu,
    group_key,
)

ORIGIN = GeodeticOrigin(36.1447, -86.8027, 180.0)
SPOOF = "RSAF800000666"
BENIGN = "RSAF800000001"


def geodetic(p_enu_m: tuple[float, float, float]) -> tuple[float, float, float]:
    lat, lon, alt = frames.enu_to_geodetic(ORIGIN, np.array(p_enu_m))
    return float(lat), float(lon), float(alt)


def observation(
    t_s: float = 1.0,
    rx_enu_m: tuple[float, float, float] = (10.0, -20.0, 30.0),
    claimed_enu_m: tuple[float, float, float] = (300.0, 400.0, 60.0),
    rid_timestamp_s: float = 1200.5,
    rssi_dbm: float = -70.0,
    uas_id: str = SPOOF,
) -> Observation:
    rx_lat, rx_lon, rx_alt = geodetic(rx_enu_m)
    c_lat, c_lon, c_alt = geodetic(claimed_enu_m)
    return Observation(
        t_s=t_s,
        rx_lat_deg=rx_lat,
        rx_lon_deg=rx_lon,
        rx_alt_m=rx_alt,
        claimed_lat_deg=c_lat,
        claimed_lon_deg=c_lon,
        claimed_alt_m=c_alt,
        rid_timestamp_s=rid_timestamp_s,
        rssi_dbm=rssi_dbm,
        claimed_course_deg=90.0,
        claimed_speed_horizontal_m_s=5.0,
        claimed_speed_vertical_m_s=-1.0,
        uas_id=uas_id,
    )


def test_one_report_becomes_one_observed_claim_in_enu() -> None:
    ingest = Ingest(GcsConfig(), ORIGIN)
    assert ingest.add(1.0, 3, observation(t_s=0.98, rssi_dbm=-71.5)) is None
    assert ingest.close_due(1.2) == []  # window 0.3 s not over yet
    (claim,) = ingest.close_due(1.3)
    assert claim.uas_id == SPOOF and claim.rid_timestamp_s == 1200.5
    np.testing.assert_allclose(claim.claimed_p_enu_m, [300.0, 400.0, 60.0], atol=1e-6)
    np.testing.assert_allclose(claim.rx_p_enu_m, [[10.0, -20.0, 30.0]], atol=1e-6)
    assert claim.rx_sysid.tolist() == [3] and claim.rx_t_s.tolist() == [0.98]
    assert claim.rssi_dbm.tolist() == [-71.5] and claim.t_s == 0.98
    assert claim.claimed_v_enu_m_s is not None
    np.testing.assert_allclose(claim.claimed_v_enu_m_s, [5.0, 0.0, -1.0], atol=1e-12)
    for array in (
        claim.claimed_p_enu_m,
        claim.rx_p_enu_m,
        claim.rx_sysid,
        claim.rssi_dbm,
        claim.rx_t_s,
    ):
        assert not array.flags.writeable
    assert ingest.counters.accepted == 1 and ingest.counters.transmissions == 1


def _replace(**changes: object) -> Observation:
    return dataclasses.replace(observation(), **changes)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("report", "reason"),
    [
        (_replace(rssi_dbm=math.nan), RejectReason.NON_FINITE),
        (_replace(rx_alt_m=math.inf), RejectReason.NON_FINITE),
        (_replace(claimed_course_deg=math.nan), RejectReason.NON_FINITE),
        (_replace(rx_lat_deg=91.0), RejectReason.LAT_LON_RANGE),
        (_replace(claimed_lon_deg=-180.5), RejectReason.LAT_LON_RANGE),
        (_replace(rssi_dbm=-200.0), RejectReason.RSSI_RANGE),
        (_replace(rssi_dbm=45.0), RejectReason.RSSI_RANGE),
        (_replace(claimed_alt_m=20_000.0), RejectReason.ALTITUDE_RANGE),
        (_replace(rx_alt_m=-600.0), RejectReason.ALTITUDE_RANGE),
        (_replace(t_s=1.6), RejectReason.FUTURE_TIME),
        (_replace(t_s=-4.5), RejectReason.TOO_OLD),
        (_replace(uas_id=""), RejectReason.EMPTY_ID),
        (_replace(uas_id="\x00\x00"), RejectReason.EMPTY_ID),
        (observation(claimed_enu_m=(150_000.0, 0.0, 60.0)), RejectReason.DISTANCE_RANGE),
    ],
    ids=lambda v: v.value if isinstance(v, RejectReason) else "",
)
def test_each_bad_report_is_counted_by_reason_and_not_raised(
    report: Observation, reason: RejectReason
) -> None:
    ingest = Ingest(GcsConfig(), ORIGIN)  # now = 1.0: future beyond 1.5, older than -4.0
    assert ingest.add(1.0, 2, report) is reason
    assert ingest.counters.rejected == {reason: 1}
    assert ingest.counters.as_dict()[f"rejected_{reason.value}"] == 1
    assert ingest.counters.accepted == 0 and ingest.open_groups == 0
    assert ingest.close_due(10.0) == []


def test_time_limits_are_inclusive_of_the_tolerance() -> None:
    ingest = Ingest(GcsConfig(future_tolerance_s=0.5, history_window_s=5.0), ORIGIN)
    assert ingest.add(10.0, 1, observation(t_s=10.5)) is None
    assert ingest.add(10.0, 2, observation(t_s=5.0)) is None


def test_a_duplicate_reception_is_dropped_and_counted() -> None:
    ingest = Ingest(GcsConfig(), ORIGIN)
    assert ingest.add(1.0, 1, observation(rssi_dbm=-60.0)) is None
    assert ingest.add(1.05, 1, observation(rssi_dbm=-80.0)) is RejectReason.DUPLICATE
    assert ingest.add(1.05, 2, observation(rssi_dbm=-65.0)) is None
    (claim,) = ingest.close_due(1.5)
    assert claim.rx_sysid.tolist() == [1, 2] and claim.rssi_dbm.tolist() == [-60.0, -65.0]
    assert ingest.counters.rejected == {RejectReason.DUPLICATE: 1}


def test_a_later_report_claiming_elsewhere_is_checked_on_its_own_claim() -> None:
    """Reports of one broadcast share its claim, and the ingest converts it once; a report
    whose claim differs is converted and range-checked by itself."""
    ingest = Ingest(GcsConfig(), ORIGIN)
    assert ingest.add(1.0, 3, observation()) is None
    far = observation(claimed_enu_m=(150_000.0, 0.0, 60.0))
    assert ingest.add(1.0, 4, far) is RejectReason.DISTANCE_RANGE
    assert ingest.add(1.0, 5, observation()) is None
    (claim,) = ingest.close_due(1.3)
    assert claim.rx_sysid.tolist() == [3, 5]
    np.testing.assert_allclose(claim.claimed_p_enu_m, [300.0, 400.0, 60.0], atol=1e-6)


def test_receptions_arriving_over_several_ticks_are_grouped_per_transmission() -> None:
    ingest = Ingest(GcsConfig(group_window_s=0.3), ORIGIN)
    arrivals = [  # (GCS time, receiver, id, rid timestamp)
        (1.00, 3, SPOOF, 1200.5),
        (1.00, 2, BENIGN, 1200.4),
        (1.10, 1, SPOOF, 1200.5),
        (1.20, 1, BENIGN, 1200.4),
        (1.25, 2, SPOOF, 1200.5),
        (1.25, 2, SPOOF, 1201.5),  # the next broadcast of the spoofer: its own group
    ]
    for now_s, rx, uas_id, rid_ts in arrivals:
        report = observation(t_s=now_s, rid_timestamp_s=rid_ts, uas_id=uas_id, rssi_dbm=-50 - rx)
        assert ingest.add(now_s, rx, report) is None
    assert ingest.close_due(1.25) == []
    closed = ingest.close_due(1.30)
    # oldest first (both first heard at 1.00), then by id
    assert [(t.uas_id, t.rid_timestamp_s) for t in closed] == [(BENIGN, 1200.4), (SPOOF, 1200.5)]
    benign, spoof = closed
    assert spoof.rx_sysid.tolist() == [1, 2, 3]  # sorted by receiver, not arrival
    assert spoof.rssi_dbm.tolist() == [-51.0, -52.0, -53.0]
    assert spoof.rx_t_s.tolist() == [1.10, 1.25, 1.00] and spoof.t_s == 1.00
    assert benign.rx_sysid.tolist() == [1, 2]
    assert ingest.open_groups == 1
    assert ingest.add(1.35, 4, observation(t_s=1.35)) is RejectReason.LATE
    (later,) = ingest.close_due(1.55)
    assert later.rid_timestamp_s == 1201.5 and later.rx_sysid.tolist() == [2]


def test_grouping_key_tolerates_float32_timestamps() -> None:
    as_float32 = float(np.float32(1200.3))
    assert group_key(SPOOF, as_float32) == group_key(SPOOF, 1200.3)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=50))
def test_the_grouping_key_is_the_timestamp_rounded_to_the_millisecond_each_time(
    timestamps: list[float],
) -> None:
    for t in timestamps + timestamps[::-1]:  # each once more: the remembered rounding
        assert group_key(SPOOF, t) == (SPOOF, round(t, 3))


def test_history_is_bounded_per_transmitter_and_in_transmitters() -> None:
    ingest = Ingest(GcsConfig(history_per_transmitter=3, max_transmitters=2), ORIGIN)
    for k in range(5):
        ingest.add(float(k), 1, observation(t_s=float(k), rid_timestamp_s=1200.0 + k))
        ingest.close_due(k + 0.5)
    history = ingest.history(SPOOF)
    assert [t.rid_timestamp_s for t in history] == [1202.0, 1203.0, 1204.0]
    ingest.add(5.0, 1, observation(t_s=5.0, uas_id=BENIGN))
    ingest.add(5.0, 1, observation(t_s=5.0, uas_id="RSAF800000002"))
    ingest.close_due(5.5)
    assert ingest.transmitters == (BENIGN, "RSAF800000002")
    assert ingest.history(SPOOF) == () and ingest.counters.evicted_transmitters == 1


def test_open_transmissions_are_bounded() -> None:
    ingest = Ingest(GcsConfig(max_open_groups=2), ORIGIN)
    for k in range(2):
        assert ingest.add(1.0, 1, observation(rid_timestamp_s=1200.0 + k)) is None
    third = observation(rid_timestamp_s=1203.0)
    assert ingest.add(1.0, 1, third) is RejectReason.TOO_MANY_GROUPS
    assert len(ingest.close_due(2.0)) == 2
    assert ingest.add(2.0, 1, dataclasses.replace(third, t_s=2.0)) is None


@pytest.mark.parametrize(
    ("course", "speed_h", "speed_v", "expected"),
    [
        (0.0, 4.0, 1.0, (0.0, 4.0, 1.0)),  # north
        (90.0, 4.0, 0.0, (4.0, 0.0, 0.0)),  # east
        (225.0, math.sqrt(2.0), -2.0, (-1.0, -1.0, -2.0)),  # south-west, descending
        (None, 0.0, 0.5, (0.0, 0.0, 0.5)),  # hovering: no course needed
        (None, 3.0, 0.0, None),  # moving with no course
        (90.0, None, 0.0, None),
        (90.0, 3.0, None, None),
    ],
)
def test_claimed_velocity_from_course_and_speeds(
    course: float | None,
    speed_h: float | None,
    speed_v: float | None,
    expected: tuple[float, float, float] | None,
) -> None:
    report = dataclasses.replace(
        observation(),
        claimed_course_deg=course,
        claimed_speed_horizontal_m_s=speed_h,
        claimed_speed_vertical_m_s=speed_v,
    )
    got = claimed_velocity_enu(report)
    if expected is None:
        assert got is None
    else:
        assert got is not None
        np.testing.assert_allclose(got, expected, atol=1e-12)


def test_rate_limited_log_warns_once_per_interval(caplog: pytest.LogCaptureFixture) -> None:
    log = RateLimitedLog(logging.getLogger("test.ratelimit"), interval_s=5.0)
    with caplog.at_level(logging.DEBUG, logger="test.ratelimit"):
        for t in (0.0, 1.0, 2.0, 6.0):
            log.warn(t, "bad", "report rejected")
        log.warn(6.5, "other", "another reason")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        "report rejected",
        "report rejected (2 more since the last warning)",
        "another reason",
    ]


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"cycle_s": 0.0}, "cycle_s"),
        ({"peer_timeout_s": math.nan}, "peer_timeout_s"),
        ({"history_per_transmitter": 0}, "history_per_transmitter"),
        ({"rssi_min_dbm": 40.0}, "rssi_min_dbm"),
        ({"alt_min_m": 20_000.0}, "alt_min_m"),
        ({"group_window_s": 6.0}, "group_window_s"),
        ({"future_tolerance_s": -1.0}, "future_tolerance_s"),
    ],
)
def test_config_rejects_impossible_values_naming_the_field(
    changes: dict[str, float], field: str
) -> None:
    with pytest.raises(FieldValueError) as info:
        GcsConfig(**changes)  # type: ignore[arg-type]
    assert info.value.field == field


def test_claims_of_one_cycle_are_built_together_each_sorted_by_receiver() -> None:
    """Several broadcasts closing in one cycle, receptions arriving out of receiver order:
    each claim holds exactly its own receptions, sorted by receiver id, read-only."""
    ingest = Ingest(GcsConfig(), ORIGIN)
    heard = {  # uas_id -> receptions (rx sysid, t, rx position, rssi) in arrival order
        SPOOF: [(9, 1.02, (5.0, 6.0, 7.0), -60.0), (2, 1.01, (1.0, 2.0, 3.0), -61.0)],
        BENIGN: [(4, 1.03, (8.0, 9.0, 10.0), -62.0), (7, 1.00, (11.0, 12.0, 13.0), -63.0)],
        "RSAF800000002": [(3, 1.04, (14.0, 15.0, 16.0), -64.0)],
    }
    for uas_id, receptions in heard.items():
        for sysid, t, rx, rssi in receptions:
            obs = observation(t_s=t, rx_enu_m=rx, rssi_dbm=rssi, uas_id=uas_id)
            assert ingest.add(1.05, sysid, obs) is None
    claims = {c.uas_id: c for c in ingest.close_due(1.4)}
    assert set(claims) == set(heard)
    for uas_id, receptions in heard.items():
        claim, expected = claims[uas_id], sorted(receptions)
        assert claim.rx_sysid.tolist() == [r[0] for r in expected]
        assert claim.rx_t_s.tolist() == [r[1] for r in expected]
        assert claim.rssi_dbm.tolist() == [r[3] for r in expected]
        np.testing.assert_allclose(claim.rx_p_enu_m, [r[2] for r in expected], atol=1e-6)
        assert claim.t_s == min(r[1] for r in receptions) == float(claim.rx_t_s.min())
        arrays = (claim.rx_sysid, claim.rx_t_s, claim.rssi_dbm, claim.rx_p_enu_m)
        for array in (*arrays, claim.claimed_p_enu_m, claim.claimed_v_enu_m_s):
            assert array is not None and not array.flags.writeable


def test_claims_closed_together_keep_their_own_claimed_position_and_velocity() -> None:
    """A cycle's claimed positions and velocities are built together: each claim gets its
    own, and one without a speed has no velocity."""
    ingest = Ingest(GcsConfig(), ORIGIN)
    moving = observation(uas_id=SPOOF, claimed_enu_m=(300.0, 400.0, 60.0))
    still = dataclasses.replace(
        observation(uas_id=BENIGN, claimed_enu_m=(-50.0, 20.0, 40.0)),
        claimed_speed_horizontal_m_s=None,
    )
    for sysid, obs in ((2, moving), (3, still)):
        assert ingest.add(1.05, sysid, obs) is None
    claims = {c.uas_id: c for c in ingest.close_due(1.4)}
    np.testing.assert_allclose(claims[SPOOF].claimed_p_enu_m, [300.0, 400.0, 60.0], atol=1e-6)
    np.testing.assert_allclose(claims[BENIGN].claimed_p_enu_m, [-50.0, 20.0, 40.0], atol=1e-6)
    velocity = claims[SPOOF].claimed_v_enu_m_s
    assert velocity is not None
    np.testing.assert_allclose(velocity, [5.0, 0.0, -1.0], atol=1e-9)
    assert claims[BENIGN].claimed_v_enu_m_s is None


def test_closed_keys_are_forgotten_oldest_first_after_the_history_window() -> None:
    cfg = GcsConfig()
    ingest = Ingest(cfg, ORIGIN)
    for k in range(3):
        obs = observation(t_s=1.0 + k, rid_timestamp_s=100.0 + k)
        assert ingest.add(1.0 + k, 1, obs) is None
        ingest.close_due(1.5 + k)
    late = observation(t_s=1.2, rid_timestamp_s=100.0)
    assert ingest.add(3.6, 2, late) is RejectReason.LATE  # its broadcast closed already
    ingest.close_due(1.5 + cfg.history_window_s + 1.1)  # the first two keys expire
    assert len(ingest._closed) == 1


def test_a_receiver_that_moves_between_reports_is_placed_where_each_report_says() -> None:
    """The per-receiver conversion memo: the same position reuses the last conversion, a new
    one is converted afresh (one receiver reports three broadcasts, moving before the last)."""
    ingest = Ingest(GcsConfig(), ORIGIN)
    first, moved = (10.0, -20.0, 30.0), (15.0, -18.0, 31.0)
    reports = [(first, 1200.5), (first, 1201.5), (moved, 1202.5)]
    for rx_enu_m, rid_timestamp_s in reports:
        assert (
            ingest.add(1.0, 7, observation(rx_enu_m=rx_enu_m, rid_timestamp_s=rid_timestamp_s))
            is None
        )
    claims = sorted(ingest.close_due(1.5), key=lambda c: c.rid_timestamp_s)
    assert len(claims) == 3
    for claim, (rx_enu_m, _) in zip(claims, reports, strict=True):
        np.testing.assert_allclose(claim.rx_p_enu_m, [rx_enu_m], atol=1e-6)


_VARIANTS: list[dict[str, object]] = [
    {},
    {},
    {"rssi_dbm": -200.0},
    {"rssi_dbm": math.nan},
    {"claimed_course_deg": math.inf},
    {"claimed_course_deg": None},
    {"claimed_speed_horizontal_m_s": None},
    {"claimed_speed_horizontal_m_s": 0.0, "claimed_course_deg": None},
    {"rx_alt_m": 20_000.0},
    {"rx_lat_deg": 91.0},
    {"rx_lon_deg": 181.0},
    {"claimed_lat_deg": -91.0},
    {"claimed_lon_deg": -180.5},
    {"claimed_alt_m": -2000.0},
    {"rssi_dbm": 45.0},
    {"t_s": 1.6},
    {"t_s": -4.5},
    {"t_s": 1.5},
    {"uas_id": ""},
    {"uas_id": " \x00"},
    {"uas_id": BENIGN},
    {"rid_timestamp_s": 1201.0},
]


@settings(max_examples=200)
@given(
    reports=st.lists(
        st.tuples(st.integers(0, len(_VARIANTS) - 1), st.integers(1, 4), st.booleans()),
        min_size=1,
        max_size=30,
    )
)
def test_rows_are_taken_as_each_report_would_be(reports: list[tuple[int, int, bool]]) -> None:
    """``add_rows`` = ``add`` of each row in order: the same reasons, counters and claims."""
    by_rows, one_by_one = Ingest(GcsConfig(), ORIGIN), Ingest(GcsConfig(), ORIGIN)
    batches: dict[int, list[Observation]] = {}
    expected: list[tuple[str, RejectReason]] = []
    for variant, rx_sysid, far in reports:
        report = _replace(**_VARIANTS[variant])
        if far:
            report = dataclasses.replace(report, rx_alt_m=report.rx_alt_m + 1.0)
        batches.setdefault(rx_sysid, []).append(report)
    for rx_sysid, batch in batches.items():
        for report in batch:
            reason = one_by_one.add(1.0, rx_sysid, report)
            if reason is not None:
                expected.append((report.uas_id, reason))
    got = [
        r
        for rx, batch in batches.items()
        for r in by_rows.add_rows(1.0, rx, ObservationRows.of(batch))
    ]
    assert got == expected
    assert by_rows.counters == one_by_one.counters
    for a, b in zip(by_rows.close_due(2.0), one_by_one.close_due(2.0), strict=True):
        assert a.uas_id == b.uas_id and a.rid_timestamp_s == b.rid_timestamp_s
        for name in ("rx_sysid", "rx_p_enu_m", "rx_t_s", "rssi_dbm", "claimed_p_enu_m"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert (a.claimed_v_enu_m_s is None) == (b.claimed_v_enu_m_s is None)
        if a.claimed_v_enu_m_s is not None and b.claimed_v_enu_m_s is not None:
            assert np.array_equal(a.claimed_v_enu_m_s, b.claimed_v_enu_m_s)
