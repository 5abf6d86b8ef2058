"""The dense-traffic gate: which heard aircraft the planner is asked to avoid."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.common.errors import FieldValueError
from ridsafe.companion.planner_api import Neighbour
from ridsafe.companion.traffic_gate import TrafficGate, closest_approach_m, gate_neighbours

GATE = TrafficGate(min_airborne=1, near_m=60.0, miss_m=75.0, horizon_s=10.0)
OWN_P = (0.0, 0.0, -50.0)
OWN_V = (8.0, 0.0, 0.0)  # north at cruise speed
GOAL = (400.0, 0.0, -50.0)  # straight ahead


def _nb(
    uas_id: str, p: tuple[float, float, float], v: tuple[float, float, float], flagged: bool = False
) -> Neighbour:
    return Neighbour(uas_id, p, v, 10.0, flagged)


def _kept(neighbours: tuple[Neighbour, ...], gate: TrafficGate = GATE) -> list[str]:
    out = gate_neighbours(10.0, OWN_P, OWN_V, GOAL, neighbours, gate, 8.0, 0.0)
    return [n.uas_id for n in out]


def test_off_hands_every_claim() -> None:
    far = (_nb("A", (0.0, 500.0, -50.0), (0.0, 8.0, 0.0)),)
    assert _kept(far, TrafficGate()) == ["A"]


def test_below_the_density_switch_every_claim_goes_through() -> None:
    claims = (_nb("A", (0.0, 500.0, -50.0), (0.0, 8.0, 0.0)), _nb("B", (0.0, -80.0, -50.0), OWN_V))
    assert _kept(claims, TrafficGate(min_airborne=3)) == ["A", "B"]
    assert _kept(claims, TrafficGate(min_airborne=2)) == []


def test_head_on_traffic_beyond_the_near_radius_is_kept() -> None:
    assert _kept((_nb("A", (150.0, 0.0, -50.0), (-8.0, 0.0, 0.0)),)) == ["A"]


def test_parallel_traffic_beside_the_track_is_left_out() -> None:
    """Side by side 80 m apart at the same speed: d_safe (100 m) would weigh it for ever."""
    assert _kept((_nb("A", (0.0, 80.0, -50.0), OWN_V),)) == []


def test_diverging_traffic_is_left_out_but_not_when_near() -> None:
    away = (0.0, 8.0, 0.0)  # flies east, away from the own track
    assert _kept((_nb("A", (0.0, 70.0, -50.0), away),)) == []
    assert _kept((_nb("B", (0.0, 50.0, -50.0), away),)) == ["B"]


def test_a_crossing_that_meets_the_track_toward_the_goal_is_kept() -> None:
    """A hovering own aircraft would miss it, the current velocity too: the goal motion not."""
    own_v_hover = (0.0, 0.0, 0.0)
    crossing = _nb("A", (80.0, 80.0, -50.0), (0.0, -8.0, 0.0))  # crosses 80 m ahead in 10 s
    out = gate_neighbours(10.0, OWN_P, own_v_hover, GOAL, (crossing,), GATE, 8.0, 0.0)
    assert [n.uas_id for n in out] == ["A"]


def test_the_claim_is_moved_to_now_along_its_velocity() -> None:
    """Heard 5 s ago 200 m ahead closing at 8 m/s: now 160 m, head-on, kept; the same claim
    flying away is left out."""
    closing = Neighbour("A", (240.0, 0.0, -50.0), (-8.0, 0.0, 0.0), 5.0, False)
    opening = Neighbour("B", (-100.0, 0.0, -50.0), (-8.0, 0.0, 0.0), 5.0, False)
    out = gate_neighbours(10.0, OWN_P, OWN_V, GOAL, (closing, opening), GATE, 8.0, 0.0)
    assert [n.uas_id for n in out] == ["A"]


def test_grounded_aircraft_are_left_out_and_flagged_claims_pass() -> None:
    parked = _nb("P", (0.0, 30.0, 0.0), (0.0, 0.0, 0.0))
    spoofer = _nb("S", (0.0, 900.0, -50.0), (0.0, 8.0, 0.0), flagged=True)
    assert _kept((parked, spoofer)) == ["S"]


def test_settings_are_checked() -> None:
    with pytest.raises(FieldValueError, match="min_airborne"):
        TrafficGate(min_airborne=-1)
    with pytest.raises(FieldValueError, match="miss_m"):
        TrafficGate(miss_m=0.0)


_coord = st.floats(-300.0, 300.0)
_speed = st.floats(-16.0, 16.0)


@settings(max_examples=200)
@given(st.tuples(_coord, _coord, _coord), st.tuples(_speed, _speed, _speed))
def test_closest_approach_matches_dense_sampling(
    r: tuple[float, float, float], u: tuple[float, float, float]
) -> None:
    """d_cpa against the minimum over 20,001 sampled times of |r + u t|, t in [0, 10 s],
    where the range shrinks; inf where it does not (the sampled range then never drops below
    where it starts: r . u is 0 up to rounding, e.g. r = (3, 0, 3), u = (1.9, 0, -1.9), and
    the sign a sum of products rounds to must not decide the test)."""
    r_m, u_m_s = np.array([r]), np.array([u])
    exact = float(closest_approach_m(r_m, u_m_s, 10.0)[0])
    t = np.linspace(0.0, 10.0, 20_001)[:, None]
    sampled = float(np.min(np.linalg.norm(r_m + u_m_s * t, axis=1)))
    if exact == np.inf:
        assert sampled >= float(np.linalg.norm(r_m)) - 1e-9
        return
    assert float(np.dot(r, u)) < 0.0
    assert exact <= sampled + 1e-9
    assert exact >= sampled - 16.0 * 10.0 / 20_000 * np.sqrt(3.0)  # one sample step of |u|
