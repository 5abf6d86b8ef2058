"""The straight approach of dense traffic: is flying straight at the goal clear?"""

from __future__ import annotations

from ridsafe.companion.goal_approach import straight_approach_clear
from ridsafe.companion.planner_api import Neighbour

P = (0.0, 0.0, -50.0)
GOAL = (30.0, 0.0, -50.0)  # 30 m north


def _clear(*neighbours: Neighbour, clear_m: float = 55.0) -> bool:
    return straight_approach_clear(10.0, P, GOAL, neighbours, 4.0, clear_m)


def test_no_neighbours_is_clear() -> None:
    assert _clear()


def test_a_hovering_aircraft_beside_the_goal_but_clear_of_the_path() -> None:
    """60 m east of the goal: 60 m from the goal, further from the rest of the path."""
    beside = Neighbour("A", (30.0, 60.0, -50.0), (0.0, 0.0, 0.0), 10.0, False)
    assert _clear(beside)
    assert not _clear(beside, clear_m=61.0)


def test_an_aircraft_crossing_the_path_later_blocks_it() -> None:
    """Now 100 m east of the goal, flying west at 8 m/s: over the goal in 12.5 s, within 55 m
    of it after 5.6 s, when the own aircraft (4 m/s) is 22 m along: blocked."""
    crossing = Neighbour("A", (30.0, 100.0, -50.0), (0.0, -8.0, 0.0), 10.0, False)
    assert not _clear(crossing)


def test_the_claim_is_moved_along_its_velocity_from_when_it_was_heard() -> None:
    """Heard 3 s ago 100 m east flying east: 124 m away now and opening: clear. The same claim
    flying west is now 76 m away and closes to 0 m within 10 s."""
    east = Neighbour("A", (30.0, 100.0, -50.0), (0.0, 8.0, 0.0), 7.0, False)
    west = Neighbour("B", (30.0, 100.0, -50.0), (0.0, -8.0, 0.0), 7.0, False)
    assert _clear(east)
    assert not _clear(west)


def test_an_aircraft_within_the_clearance_now_blocks() -> None:
    """45 m behind the own aircraft, though the path leads away from it: not clear."""
    behind = Neighbour("A", (-45.0, 0.0, -50.0), (0.0, 0.0, 0.0), 10.0, False)
    assert not _clear(behind)
