"""The family's launch schedule: the paper's draws kept, every launch in the window, pads in
the area and never reused too soon, deliveries a late launch can finish, refusals that name
the keys to change."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ridsafe.tools.run.family_launches import (
    DepotPads,
    FamilyDrawError,
    PadChoice,
    launch_schedule,
    pad_offsets_enu_m,
)
from ridsafe.tools.run.scenario import load_scenario_file
from ridsafe.tools.run.scenario_family import FamilyConfig, generate

PAPER = load_scenario_file("configs/paper.yaml")
CITY = load_scenario_file("configs/city.yaml")
assert PAPER.family is not None and CITY.family is not None
# The paper's family on its one square kilometre, the cadence alone adapting to N (the
# config copies the area beyond 16 aircraft: test_scenario_family.py).
PAPER_FAMILY = dataclasses.replace(PAPER.family, tile_capacity=None)
CITY_FAMILY = CITY.family


def _ring_pad(depot: tuple[float, float, float], slot: int, spacing_m: float) -> np.ndarray:
    """The paper's pad layout written out (slots 0-18): the centre, then rings of 6 and 12."""
    if slot == 0:
        return np.array(depot)
    ring = 1 if slot <= 6 else 2
    index = slot - 1 if slot <= 6 else slot - 7
    angle = 2 * math.pi * index / (6 * ring)
    return np.array(depot) + ring * spacing_m * np.array([math.cos(angle), math.sin(angle), 0.0])


def test_the_paper_densities_launch_as_they_always_did() -> None:
    """Up to 16 aircraft: 4 s apart, nothing adapted; with ``pad_choice: in_turn`` from the
    ring pads in order and trips measured from the depot (the scenarios of the reports flown
    before pads faced the deliveries)."""
    launches = launch_schedule(16, PAPER_FAMILY.launch_rules)
    in_turn = dataclasses.replace(PAPER_FAMILY, pad_choice=PadChoice.IN_TURN)
    drawn = generate(PAPER.scenario, 16, 3, in_turn).aircraft
    for k, (launch, a) in enumerate(zip(launches, drawn, strict=True)):
        depot = PAPER_FAMILY.depots_enu_m[k % 3]
        assert launch.depot_index == k % 3
        assert launch.departure_s == a.departure_s == (k // 3) * 4.0
        expected = _ring_pad(depot, k // 3, PAPER_FAMILY.pad_spacing_m)
        np.testing.assert_allclose(launch.pad_enu_m, expected, atol=1e-9)
        np.testing.assert_allclose(a.start_enu_m, expected, atol=1e-9)
        trip_m = math.dist(depot[:2], a.goal_enu_m[:2])
        assert in_turn.min_trip_m <= trip_m <= in_turn.max_trip_m


def test_a_launch_takes_the_free_pad_furthest_toward_its_delivery() -> None:
    """The pad facing the site; the next launch that way, while it is busy, the next pad
    along the bearing; after ``pad_reuse_s`` it again."""
    rules = dataclasses.replace(PAPER_FAMILY, half_width_m=1000.0).launch_rules
    pads = DepotPads((0.0, 0.0, 0.0), rules)
    east = (400.0, 5.0, 0.0)  # a little north: the 30 degree pad is the next along
    first = pads.facing(east, 0.0)
    np.testing.assert_allclose(first, (110.0, 0.0, 0.0), atol=1e-9)
    pads.take(first, 0.0)
    second = pads.facing(east, 4.0)
    np.testing.assert_allclose(second, (110.0 * math.cos(math.pi / 6), 55.0, 0.0), atol=1e-9)
    pads.take(second, 4.0)
    west = pads.facing((-300.0, 10.0, 0.0), 8.0)
    assert west[0] < -100.0  # the other side of the depot is free
    assert pads.facing(east, 4.0 + rules.pad_reuse_s) == first


@pytest.mark.parametrize("n_aircraft", [1, 16, 24, 32, 48, 64, 96])
def test_every_launch_in_the_window_from_a_pad_inside_the_area(n_aircraft: int) -> None:
    family = PAPER_FAMILY
    launches = launch_schedule(n_aircraft, family.launch_rules)
    assert max(launch.departure_s for launch in launches) <= family.launch_window_s + 1e-9
    limit_m = family.half_width_m - family.pad_margin_m
    for launch in launches:
        assert max(abs(launch.pad_enu_m[0]), abs(launch.pad_enu_m[1])) <= limit_m
    by_pad: dict[tuple[float, float, float], list[float]] = {}
    for launch in launches:
        by_pad.setdefault(launch.pad_enu_m, []).append(launch.departure_s)
    for times in by_pad.values():
        assert np.all(np.diff(sorted(times)) >= family.pad_reuse_s)


def _latest_nominal_arrival_s(n_aircraft: int, seed: int) -> float:
    """When the last of the scenario's nominal flights (take-off, then straight at the
    nominal speed) reaches its site."""
    family = PAPER_FAMILY
    return max(
        a.departure_s
        + family.nominal_takeoff_s
        + math.dist(a.start_enu_m[:2], a.goal_enu_m[:2]) / family.nominal_speed_m_s
        for a in generate(PAPER.scenario, n_aircraft, seed, family).aircraft
    )


def test_late_launches_get_deliveries_a_nominal_flight_finishes_by_the_deadline() -> None:
    for n_aircraft in (32, 64, 96):
        for seed in range(5):
            # 1e-3 s: sites and pads are stored to the millimetre (8 m/s: 1.25e-4 s per mm)
            latest_s = _latest_nominal_arrival_s(n_aircraft, seed)
            assert latest_s <= PAPER_FAMILY.delivery_deadline_s + 1e-3


def test_the_deadline_is_the_latest_nominal_arrival_the_paper_densities_can_draw() -> None:
    """So it never binds at 4-16 aircraft (their draws are those of the reports), and a
    denser family's last launches keep as much of the run for traffic as the paper's do."""
    family = PAPER_FAMILY
    last_departure_s = max(a.departure_s for a in generate(PAPER.scenario, 16, 0, family).aircraft)
    paper_latest_s = (
        last_departure_s + family.nominal_takeoff_s + family.max_trip_m / family.nominal_speed_m_s
    )
    assert paper_latest_s <= family.delivery_deadline_s <= paper_latest_s + 1.0


def test_too_many_aircraft_per_depot_is_refused_naming_the_flag_and_keys() -> None:
    with pytest.raises(FamilyDrawError) as error:
        generate(PAPER.scenario, 128, 0, PAPER_FAMILY)
    text = str(error.value)
    assert "--aircraft 128" in text and "family.min_launch_interval_s" in text
    assert "family.depots_enu_m" in text and "family.tile_capacity" in text


def test_the_paper_config_gives_128_aircraft_nine_square_kilometres_instead() -> None:
    """What one square kilometre refuses, configs/paper.yaml flies on 3 x 3 copies of it,
    each depot launching at the paper's own cadence (at most 5 aircraft, every 4 s)."""
    assert PAPER.family is not None
    aircraft = generate(PAPER.scenario, 128, 0, PAPER.family).aircraft
    assert len(aircraft) == 128
    assert max(a.departure_s for a in aircraft) == 4 * PAPER_FAMILY.launch_interval_s
    assert max(abs(c) for a in aircraft for c in a.start_enu_m[:2]) > 1000.0


def test_a_pad_reused_too_soon_is_refused() -> None:
    family = dataclasses.replace(PAPER_FAMILY, max_pad_rings=0)  # one pad per depot
    with pytest.raises(FamilyDrawError, match=r"family\.pad_reuse_s"):
        launch_schedule(48, family.launch_rules)  # 16 launches 2.7 s apart from one pad


def test_a_depot_outside_the_area_is_refused() -> None:
    family = dataclasses.replace(PAPER_FAMILY, depots_enu_m=((900.0, 0.0, 0.0),))
    with pytest.raises(FamilyDrawError, match=r"depots_enu_m\[0\]"):
        launch_schedule(4, family.launch_rules)


def test_pads_of_a_depot_at_the_edge_stay_inside() -> None:
    rules = PAPER_FAMILY.launch_rules
    pads = pad_offsets_enu_m((0.0, 400.0, 0.0), rules)
    assert len(pads) < 19  # the northern ring-2 pads would stand beyond the edge
    assert all(p[1] <= rules.half_width_m - rules.pad_margin_m for p in pads)


def test_a_deadline_no_late_launch_can_meet_is_a_config_error() -> None:
    with pytest.raises(ValueError, match="delivery_deadline_s"):
        FamilyConfig(delivery_deadline_s=60.0)


def test_the_city_draws_128_aircraft_and_several_spoofers() -> None:
    scenario = generate(CITY.scenario, 128, 0, CITY_FAMILY)
    assert len(scenario.aircraft) == 128
    assert len(scenario.all_spoofers) >= 3
    assert max(a.departure_s for a in scenario.aircraft) <= 40.0
    half = CITY_FAMILY.half_width_m
    assert all(max(abs(a.start_enu_m[0]), abs(a.start_enu_m[1])) <= half for a in scenario.aircraft)
