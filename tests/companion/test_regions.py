"""The unsafe-region store (expiry, DELETED, stale estimates), alerts, and the neighbour table
(expiry, flagging, the RID velocity convention); conversions into the local NED frame.

Oracles: ``frames.geodetic_to_ned`` for positions; hand-computed courses for velocities
(asymmetric: course 30 deg, so north and east differ).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ridsafe.common import frames, rid
from ridsafe.common import messages as m
from ridsafe.common.heard import claim_of, velocity_ned
from ridsafe.common.messages import AlertState, RegionFlags
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.planner_api import Vec3
from ridsafe.companion.regions import RegionStore, cov_matrix

HOME = frames.GeodeticOrigin(36.1447, -86.8027, 180.0)
SPOOFER = "RSAF800000666"


def to_local(lat: float, lon: float, alt: float) -> Vec3:
    p = frames.geodetic_to_ned(HOME, lat, lon, alt)
    return (float(p[0]), float(p[1]), float(p[2]))


def region(
    t_s: float,
    valid_s: float = 1.0,
    uas_id: str = SPOOFER,
    flags: int = 0,
    ned: tuple[float, float, float] = (100.0, -50.0, -60.0),
) -> m.UnsafeRegionMsg:
    lat, lon, alt = frames.ned_to_geodetic(HOME, np.array(ned))
    return m.UnsafeRegionMsg(
        t_s, t_s + valid_s, float(lat), float(lon), float(alt),
        (400.0, 30.0, -5.0, 200.0, 7.0, 90.0), (5.0, -2.0, 0.5), 7.8147, 0.05, 1, flags, uas_id,
    )  # fmt: skip


def alert(t_s: float, state: AlertState, uas_id: str = SPOOFER) -> m.SpoofAlert:
    return m.SpoofAlert(t_s, 20.0, 11.3, int(m.RidsafeDetector.FORCED), int(state), uas_id)


# --- regions ------------------------------------------------------------------------------------


def test_a_region_reaches_the_planner_in_local_ned_with_a_symmetric_covariance() -> None:
    store = RegionStore()
    assert store.on_region(5.0, region(5.0)) == "new"
    (r,) = store.regions(5.5, to_local)
    np.testing.assert_allclose(r.center_ned_m, (100.0, -50.0, -60.0), atol=1e-6)
    assert r.cov_ned_m2 == ((400.0, 30.0, -5.0), (30.0, 200.0, 7.0), (-5.0, 7.0, 90.0))
    cov = np.array(r.cov_ned_m2)
    np.testing.assert_array_equal(cov, cov.T)
    assert (r.uas_id, r.chi2_threshold, r.v_ned_m_s) == (SPOOFER, 7.8147, (5.0, -2.0, 0.5))
    assert (r.t_s, r.valid_until_s) == (5.0, 6.0)


def test_cov_matrix_unpacks_the_upper_triangle_row_by_row() -> None:
    assert cov_matrix((1, 2, 3, 4, 5, 6)) == ((1, 2, 3), (2, 4, 5), (3, 5, 6))


def test_a_region_expires_after_valid_until() -> None:
    store = RegionStore()
    store.on_region(5.0, region(5.0, valid_s=1.0))
    assert len(store.regions(6.0, to_local)) == 1  # valid up to and including 6.0
    assert store.regions(6.01, to_local) == ()
    assert store.counters.expired == 1


def test_a_newer_estimate_replaces_and_an_older_one_is_ignored() -> None:
    store = RegionStore()
    store.on_region(5.0, region(5.0, ned=(1.0, 0.0, -50.0)))
    assert store.on_region(5.3, region(5.25, ned=(2.0, 0.0, -50.0))) == "replaced"
    assert store.on_region(5.3, region(5.0, ned=(9.0, 0.0, -50.0))) == "stale"
    (r,) = store.regions(5.3, to_local)
    assert r.center_ned_m[0] == pytest.approx(2.0, abs=1e-6)
    assert store.counters.stale == 1 and store.counters.replaced == 1


def test_deleted_removes_the_region_of_that_id_only() -> None:
    store = RegionStore()
    store.on_region(5.0, region(5.0))
    store.on_region(5.0, region(5.0, uas_id="RSAF800000777"))
    assert store.on_region(5.5, region(5.5, flags=RegionFlags.DELETED)) == "deleted"
    assert [r.uas_id for r in store.regions(5.5, to_local)] == ["RSAF800000777"]
    assert store.on_region(5.6, region(5.6, flags=RegionFlags.DELETED)) == "deleted_unknown"
    assert store.counters.deleted == 1


def test_a_region_already_expired_when_it_comes_is_not_kept() -> None:
    store = RegionStore()
    assert store.on_region(10.0, region(5.0, valid_s=1.0)) == "expired_on_arrival"
    assert store.regions(10.0, to_local) == ()


def test_alerts_raise_and_clear_and_an_older_alert_does_not_undo_a_newer() -> None:
    store = RegionStore()
    assert store.on_alert(alert(5.0, AlertState.RAISED))
    assert store.flagged == frozenset({SPOOFER})
    assert not store.on_alert(alert(5.5, AlertState.RAISED))  # no change
    assert not store.on_alert(alert(4.0, AlertState.CLEARED))  # older: ignored
    assert store.is_flagged(SPOOFER)
    assert store.on_alert(alert(9.0, AlertState.CLEARED))
    assert store.flagged == frozenset()
    assert (store.counters.alerts_raised, store.counters.alerts_cleared) == (1, 1)


# --- neighbours ---------------------------------------------------------------------------------


def _claim(serial: str, ned: tuple[float, float, float], v_ned: Vec3) -> m.OdidLocation:
    lat, lon, alt = frames.ned_to_geodetic(HOME, np.array(ned))
    state = rid.OwnState(1.7e9, float(lat), float(lon), float(alt), 60.0, v_ned, True)
    return replace(rid.location(state), id_or_mac=serial.encode())


def test_velocity_from_course_and_speeds_is_ned() -> None:
    loc = replace(
        _claim("RSAF800000002", (0, 0, 0), (0, 0, 0)),
        course_deg=30.0,
        speed_horizontal_m_s=4.0,
        speed_vertical_m_s=1.5,  # climbing
    )
    vn, ve, vd = velocity_ned(loc)
    assert (vn, ve, vd) == pytest.approx((4.0 * math.cos(math.radians(30)), 2.0, -1.5))
    unknown = replace(loc, course_deg=None, speed_horizontal_m_s=None, speed_vertical_m_s=None)
    assert velocity_ned(unknown) == (0.0, 0.0, 0.0)


def test_rid_location_round_trip_gives_back_the_velocity() -> None:
    v = (3.0, -4.0, 0.5)
    got = velocity_ned(_claim("RSAF800000002", (0, 0, 0), v))
    assert got == pytest.approx(v, abs=1e-9)


def test_neighbours_are_in_local_ned_flagged_by_alert_and_exclude_ourselves() -> None:
    table = NeighbourTable("RSAF800000001", max_age_s=3.0)
    assert not table.update(1.0, claim_of(_claim("RSAF800000001", (0, 0, -50), (0, 0, 0))))
    assert table.update(
        1.0, claim_of(_claim("RSAF800000002", (200.0, 10.0, -60.0), (1.0, 2.0, 0.0)))
    )
    assert table.update(1.2, claim_of(_claim(SPOOFER, (-80.0, 40.0, -55.0), (0.0, 7.0, 0.0))))
    got = {n.uas_id: n for n in table.neighbours(2.0, to_local, flagged={SPOOFER})}
    assert set(got) == {"RSAF800000002", SPOOFER}
    np.testing.assert_allclose(got["RSAF800000002"].p_ned_m, (200.0, 10.0, -60.0), atol=1e-6)
    assert got["RSAF800000002"].v_ned_m_s == pytest.approx((1.0, 2.0, 0.0))
    assert got[SPOOFER].flagged and not got["RSAF800000002"].flagged
    assert got[SPOOFER].t_s == 1.2


def test_neighbours_expire_after_max_age_and_keep_only_the_latest_claim() -> None:
    table = NeighbourTable("RSAF800000001", max_age_s=3.0)
    table.update(1.0, claim_of(_claim("RSAF800000002", (10.0, 0.0, -50.0), (0, 0, 0))))
    table.update(2.0, claim_of(_claim("RSAF800000002", (20.0, 0.0, -50.0), (0, 0, 0))))
    table.update(
        1.5, claim_of(_claim("RSAF800000002", (15.0, 0.0, -50.0), (0, 0, 0)))
    )  # late, older
    (n,) = table.neighbours(4.9, to_local)
    assert n.p_ned_m[0] == pytest.approx(20.0, abs=1e-6)
    assert table.neighbours(5.01, to_local) == ()


def test_a_claim_is_converted_once_per_frame_and_again_when_anything_changes() -> None:
    calls: list[tuple[float, float, float]] = []

    def counted(lat: float, lon: float, alt: float) -> Vec3:
        calls.append((lat, lon, alt))
        return to_local(lat, lon, alt)

    table = NeighbourTable("RSAF800000001", max_age_s=3.0)
    table.update(1.0, claim_of(_claim("RSAF800000002", (200.0, 10.0, -60.0), (1.0, 2.0, 0.0))))
    table.update(1.0, claim_of(_claim(SPOOFER, (-80.0, 40.0, -55.0), (0.0, 7.0, 0.0))))
    frame = (HOME, (0.0, 0.0, 0.0))
    first = table.neighbours(1.5, counted, frame=frame)
    assert first == table.neighbours(1.5, to_local)  # the same as without a frame
    assert len(calls) == 2
    again = table.neighbours(2.0, counted, frame=(HOME, (0.0, 0.0, 0.0)))  # an equal frame
    assert again == first and all(a is b for a, b in zip(again, first, strict=True))
    assert len(calls) == 2
    table.update(
        2.1, claim_of(_claim(SPOOFER, (-70.0, 40.0, -55.0), (0.0, 7.0, 0.0)))
    )  # a new claim
    newer = table.neighbours(2.2, counted, frame=frame)
    assert len(calls) == 3 and newer[0] is first[0]
    assert newer[1].p_ned_m[0] == pytest.approx(-70.0, abs=1e-6)
    flagged = table.neighbours(2.2, counted, flagged={SPOOFER}, frame=frame)  # a new flag
    assert flagged[1].flagged and len(calls) == 4
    moved = table.neighbours(2.3, counted, flagged={SPOOFER}, frame=(HOME, (1.0, 0.0, 0.0)))
    assert len(calls) == 6 and moved == table.neighbours(2.3, to_local, flagged={SPOOFER})
    table.neighbours(2.3, counted, flagged={SPOOFER})  # no frame: every claim converted
    assert len(calls) == 8


def test_the_answer_is_kept_while_no_claim_comes_or_goes_and_the_flags_stay() -> None:
    table = NeighbourTable("RSAF800000001", max_age_s=3.0)
    table.update(1.0, claim_of(_claim("RSAF800000002", (200.0, 10.0, -60.0), (1.0, 2.0, 0.0))))
    table.update(2.0, claim_of(_claim(SPOOFER, (-80.0, 40.0, -55.0), (0.0, 7.0, 0.0))))
    frame = (HOME, (0.0, 0.0, 0.0))
    first = table.neighbours(2.5, to_local, flagged=frozenset(), frame=frame)
    assert table.neighbours(3.0, to_local, flagged=frozenset(), frame=frame) is first
    flagged = table.neighbours(3.0, to_local, flagged={SPOOFER}, frame=frame)
    assert flagged != first and flagged[1].flagged
    assert table.neighbours(3.5, to_local, flagged={SPOOFER}, frame=frame) is flagged
    table.update(
        3.6, claim_of(_claim(SPOOFER, (-70.0, 40.0, -55.0), (0.0, 7.0, 0.0)))
    )  # a new claim
    newer = table.neighbours(3.7, to_local, flagged={SPOOFER}, frame=frame)
    assert newer[1].p_ned_m[0] == pytest.approx(-70.0, abs=1e-6)
    # 4.01 s: the claim heard at 1.0 s is gone, the answer given at 3.7 s with it.
    (left,) = table.neighbours(4.01, to_local, flagged={SPOOFER}, frame=frame)
    assert left.uas_id == SPOOFER and left is newer[1]
    assert table.neighbours(6.5, to_local, flagged={SPOOFER}, frame=frame) == (left,)
    assert table.neighbours(6.61, to_local, flagged={SPOOFER}, frame=frame) == ()
    assert len(table) == 0


def test_a_claim_without_position_is_counted_unusable() -> None:
    table = NeighbourTable("RSAF800000001")
    loc = replace(_claim("RSAF800000002", (0, 0, 0), (0, 0, 0)), lat_deg=None, lon_deg=None)
    assert not table.update(1.0, claim_of(loc))
    assert table.unusable == 1 and len(table) == 0
