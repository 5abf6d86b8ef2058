"""The pad rule: what covers a pad, and the mission holding take-off and landing for it."""

from __future__ import annotations

from dataclasses import replace

from ridsafe.companion.config import CompanionConfig, OnArrival
from ridsafe.companion.mission import FlightStatus, Mission, Phase
from ridsafe.companion.pad_clearance import on_ground, pad_blocker
from ridsafe.companion.planner_api import Neighbour, Region

PAD = (0.0, 0.0, 0.0)


def _region(
    center: tuple[float, float, float], v: tuple[float, float, float] = (0, 0, 0)
) -> Region:
    cov = ((25.0, 0.0, 0.0), (0.0, 100.0, 0.0), (0.0, 0.0, 25.0))  # 10 m east-west sigma
    return Region("SPOOF", center, cov, 4.0, v, 10.0, 100.0)  # semi-axis 2 x 10 = 20 m


def _aircraft(
    p: tuple[float, float, float], v: tuple[float, float, float] = (0, 0, 0)
) -> Neighbour:
    return Neighbour("OTHER", p, v, 10.0, False)


def _blocker(
    neighbours: tuple[Neighbour, ...] = (), regions: tuple[Region, ...] = ()
) -> str | None:
    return pad_blocker(PAD, 10.0, neighbours, regions, 30.0, 10.0, 30.0)


def test_a_region_over_the_pad_blocks_it_whatever_its_height() -> None:
    assert _blocker(regions=(_region((40.0, 0.0, -60.0)),)) == "region SPOOF"  # 40 - 20 < 30


def test_a_region_further_than_its_footprint_and_the_clearance_does_not() -> None:
    assert _blocker(regions=(_region((0.0, 55.0, -60.0)),)) is None  # 55 - 20 >= 30


def test_a_region_coming_at_the_pad_blocks_it_before_it_arrives() -> None:
    coming = _region((100.0, 0.0, -60.0), (-7.0, 0.0, 0.0))  # 30 m off in 10 s
    leaving = _region((100.0, 0.0, -60.0), (7.0, 0.0, 0.0))
    assert _blocker(regions=(coming,)) == "region SPOOF"
    assert _blocker(regions=(leaving,)) is None


def test_a_radio_on_the_ground_blocks_only_the_pad_its_footprint_covers() -> None:
    """A ghost's region (``on_ground``): no clearance, it is no aircraft the climb could meet."""
    beside = replace(_region((40.0, 0.0, -5.0)), on_ground=True)  # 40 - 20 < 30, but > 0
    over = replace(_region((15.0, 0.0, -5.0)), on_ground=True)  # 15 - 20 < 0: covers the pad
    assert _blocker(regions=(beside,)) is None
    assert _blocker(regions=(replace(beside, on_ground=False),)) == "region SPOOF"
    assert _blocker(regions=(over,)) == "region SPOOF"


def test_an_expired_region_blocks_nothing() -> None:
    assert _blocker(regions=(replace(_region(PAD), valid_until_s=5.0),)) is None


def test_an_aircraft_low_over_the_pad_blocks_it_one_high_above_or_aside_does_not() -> None:
    assert _blocker((_aircraft((10.0, 5.0, -12.0)),)) == "aircraft OTHER"
    assert _blocker((_aircraft((10.0, 5.0, -60.0)),)) is None  # above the ceiling
    assert _blocker((_aircraft((55.0, 0.0, -12.0)),)) is None  # the next pad's climb


def test_an_aircraft_parked_on_the_ground_blocks_nothing() -> None:
    parked = _aircraft((5.0, 0.0, -0.3))
    assert on_ground(parked)
    assert _blocker((parked,)) is None
    assert not on_ground(_aircraft((5.0, 0.0, -0.3), (0.0, 0.0, -2.5)))  # lifting off


# --- the mission holds ---------------------------------------------------------------------


def test_take_off_waits_while_the_pad_is_covered() -> None:
    mission = Mission(CompanionConfig(), 3)
    mission.phase = Phase.WAIT_DEPARTURE
    phases = []
    for t, clear in ((10.0, False), (10.5, False), (11.0, True)):
        status = FlightStatus(link_up=True, heartbeat_s=t, departure_due=True, pad_clear=clear)
        mission.step(t, status)
        phases.append(mission.phase)
    assert phases == [Phase.WAIT_DEPARTURE, Phase.WAIT_DEPARTURE, Phase.SET_GUIDED]


def test_landing_is_not_handed_over_while_the_delivery_point_is_covered() -> None:
    mission = Mission(replace(CompanionConfig(), on_arrival=OnArrival.LAND), 3)
    mission.phase = Phase.DESCEND
    covered = FlightStatus(True, 1.0, True, 11.0, 2.0, 1.0, 1.0, pad_clear=False)
    assert mission.step(1.0, covered) == []
    assert mission.phase is Phase.DESCEND
    mission.step(1.5, replace(covered, pad_clear=True))
    assert _phase(mission) is Phase.LAND


def _phase(mission: Mission) -> Phase:
    """The phase now (a call, so the type checker does not carry an earlier narrowing)."""
    return mission.phase
