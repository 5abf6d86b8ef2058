"""The scenario family: matched seeds, valid geometry, the spoofer crossing the traffic."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.scenario import Scenario
from ridsafe.tools.run.family_launches import PadChoice, pad_offsets_enu_m
from ridsafe.tools.run.scenario import load_scenario_file
from ridsafe.tools.run.scenario_family import (
    FamilyConfig,
    _nominal_encounters,
    _nominal_flights,
    generate,
)

BASE = load_scenario_file().scenario
FAMILY = FamilyConfig()


def test_same_seed_same_scenario_and_densities_share_their_first_aircraft() -> None:
    a16 = generate(BASE, 16, 7, FAMILY)
    assert generate(BASE, 16, 7, FAMILY) == a16
    a8 = generate(BASE, 8, 7, FAMILY)
    assert a8.aircraft == a16.aircraft[:8]
    assert generate(BASE, 16, 8, FAMILY).aircraft != a16.aircraft


def test_geometry_depots_trips_departures_and_serials() -> None:
    for seed in range(20):
        s = generate(BASE, 16, seed, FAMILY)
        assert len({a.serial for a in s.aircraft}) == 16
        for k, a in enumerate(s.aircraft):
            depot = np.array(FAMILY.depots_enu_m[k % 3])
            assert (
                np.hypot(*(np.array(a.start_enu_m) - depot)[:2]) <= 2 * FAMILY.pad_spacing_m + 1e-6
            )
            trip = math.dist(a.start_enu_m[:2], a.goal_enu_m[:2])
            assert FAMILY.min_trip_m <= trip <= FAMILY.max_trip_m  # drawn from the pad
            assert all(abs(c) <= FAMILY.half_width_m for c in a.goal_enu_m[:2])
            assert a.departure_s == (k // 3) * FAMILY.launch_interval_s
            assert a.cruise_alt_m in FAMILY.cruise_alts_m


@pytest.mark.parametrize("n_aircraft", [30, 64])
def test_pads_in_use_together_stand_further_apart_than_the_nmac_radius(n_aircraft: int) -> None:
    """Two launches of a depot within ``pad_reuse_s`` of each other use pads at least
    ``pad_spacing_m`` (> the 50 m NMAC radius) apart; a pad launches again only after it."""
    aircraft = generate(BASE, n_aircraft, 0, FAMILY).aircraft
    for depot in range(3):
        launches = aircraft[depot::3]
        for i, a in enumerate(launches):
            for b in launches[i + 1 :]:
                if b.departure_s - a.departure_s < FAMILY.pad_reuse_s - 1e-9:
                    gap_m = math.dist(a.start_enu_m, b.start_enu_m)
                    assert gap_m >= FAMILY.pad_spacing_m - 0.01  # mm rounding


def _climb_outs_over_another_pad(family: FamilyConfig, n_aircraft: int) -> float:
    """The fraction of trips whose straight line from the pad passes within 25 m of another
    pad of its depot (10 seeds)."""
    crossing = []
    for seed in range(10):
        for k, a in enumerate(generate(BASE, n_aircraft, seed, family).aircraft):
            pad, site = np.array(a.start_enu_m[:2]), np.array(a.goal_enu_m[:2])
            trip = site - pad
            others = [
                np.array(p[:2])
                for p in pad_offsets_enu_m(family.depots_enu_m[k % 3], family.launch_rules)
                if math.dist(p[:2], pad) > 1.0
            ]
            along = [np.clip(np.dot(p - pad, trip) / np.dot(trip, trip), 0.0, 1.0) for p in others]
            closest_m = min(
                float(np.linalg.norm(pad + t * trip - p))
                for t, p in zip(along, others, strict=True)
            )
            crossing.append(closest_m < 25.0)
    return float(np.mean(crossing))


def test_departures_leave_their_depot_behind_them() -> None:
    """A launch takes the free pad facing its delivery: at 16 and 32 aircraft no straight
    climb-out passes over another pad of the depot, against most of them with pads in turn;
    at 64, with a third of the pads busy, a few do."""
    in_turn = dataclasses.replace(FAMILY, pad_choice=PadChoice.IN_TURN)
    assert _climb_outs_over_another_pad(FAMILY, 16) == 0.0
    assert _climb_outs_over_another_pad(FAMILY, 32) == 0.0
    assert _climb_outs_over_another_pad(FAMILY, 64) < 0.25
    assert _climb_outs_over_another_pad(in_turn, 16) > 0.75
    assert _climb_outs_over_another_pad(in_turn, 32) > 0.75


def test_spoofer_crosses_the_area_near_its_centre() -> None:
    for seed in range(20):
        spoofer = generate(BASE, 4, seed, FAMILY).spoofer
        assert spoofer is not None
        start, goal = np.array(spoofer.start_enu_m), np.array(spoofer.goal_enu_m)
        direction = (goal - start) / np.linalg.norm(goal - start)
        closest = start + direction * np.dot(-start, direction)  # point nearest the centre
        assert np.hypot(*closest[:2]) <= FAMILY.spoofer_through_radius_m + 1e-6
        assert np.linalg.norm(goal - start) >= 2 * FAMILY.half_width_m
        assert spoofer.offset_enu_m == (50.0, 50.0, 0.0)


def test_the_spoofer_aims_at_the_traffic_and_leaves_the_aircraft_alone() -> None:
    random_line = dataclasses.replace(FAMILY, spoofer_candidate_lines=1)
    aimed_met, random_met = 0, 0
    for seed in range(20):
        aimed, plain = generate(BASE, 16, seed, FAMILY), generate(BASE, 16, seed, random_line)
        assert aimed.aircraft == plain.aircraft
        assert aimed.spoofer is not None and plain.spoofer is not None
        t_s = np.arange(0.0, 120.0, 0.5)
        flights_enu_m = _nominal_flights(aimed.aircraft, t_s, FAMILY)
        met = _nominal_encounters(flights_enu_m, t_s, aimed.spoofer, FAMILY)
        met_random = _nominal_encounters(flights_enu_m, t_s, plain.spoofer, FAMILY)
        assert met >= met_random  # the random line is the first candidate
        aimed_met, random_met = aimed_met + met, random_met + met_random
    assert aimed_met >= 1.5 * random_met > 0


def test_nominal_flight_climbs_cruises_and_lands_on_its_goal() -> None:
    a = generate(BASE, 1, 0, FAMILY).aircraft[0]
    t_s = np.arange(0.0, 200.0, 0.5)
    (enu,) = _nominal_flights([a], t_s, FAMILY)
    assert np.allclose(enu[0], [*a.start_enu_m[:2], 0.0])
    assert np.allclose(enu[-1], [*a.goal_enu_m[:2], 0.0])
    assert enu[:, 2].max() == a.cruise_alt_m
    speed = np.linalg.norm(np.diff(enu[:, :2], axis=0), axis=1) / 0.5
    assert speed.max() <= FAMILY.nominal_speed_m_s + 1e-9


def test_paper_mode_flies_the_same_scenarios_as_paper() -> None:
    """The side-by-side report compares the two configs: same family, same placeholders."""
    paper, paper_mode = (load_scenario_file(f"configs/{n}.yaml") for n in ("paper", "paper_mode"))
    assert paper_mode.family == paper.family
    assert paper_mode.scenario.aircraft == paper.scenario.aircraft
    assert paper_mode.scenario.spoofer == paper.scenario.spoofer
    assert paper_mode.scenario.radio == paper.scenario.radio


def test_the_default_config_draws_from_the_paper_family() -> None:
    """`ridsafe run --aircraft N` (and bench_lockstep) fly the family the paper's sweeps fly:
    beyond 16 aircraft on a larger world, not a fuller sky."""
    default, paper = load_scenario_file(), load_scenario_file("configs/paper.yaml")
    assert default.family == paper.family
    assert default.family is not None and default.family.tile_capacity == 16


def test_cruise_altitude_by_heading_layers_the_traffic_and_keeps_the_draws() -> None:
    """Two layers: trips heading into the eastern half-plane of bearings (0-180 deg from east,
    counter-clockwise: northward) cruise at the first altitude, the others at the second;
    pads, goals and departures are those of the random draw."""
    layered = dataclasses.replace(FAMILY, cruise_alts_m=(30.0, 85.0), cruise_alt_by_heading=True)
    for seed in range(5):
        drawn = generate(BASE, 32, seed, dataclasses.replace(FAMILY, cruise_alts_m=(30.0, 85.0)))
        by_heading = generate(BASE, 32, seed, layered)
        for a, b in zip(drawn.aircraft, by_heading.aircraft, strict=True):
            assert (a.start_enu_m, a.goal_enu_m, a.departure_s) == (
                b.start_enu_m,
                b.goal_enu_m,
                b.departure_s,
            )
            north = b.goal_enu_m[1] - b.start_enu_m[1]
            assert b.cruise_alt_m == (30.0 if north >= 0.0 else 85.0)
        assert {a.cruise_alt_m for a in by_heading.aircraft} == {30.0, 85.0}


TILED = dataclasses.replace(FAMILY, tile_capacity=16)


def test_up_to_the_tile_capacity_a_tiled_family_draws_the_same_scenarios() -> None:
    """The paper's densities are drawn as before: a capacity of 16 changes nothing at 4-16."""
    for n_aircraft in (4, 8, 12, 16):
        for seed in range(5):
            assert generate(BASE, n_aircraft, seed, TILED) == generate(
                BASE, n_aircraft, seed, FAMILY
            )


@pytest.mark.parametrize(("n_aircraft", "per_side"), [(17, 2), (64, 2), (65, 3), (128, 3)])
def test_more_aircraft_than_a_tile_holds_fly_on_copies_of_the_area(
    n_aircraft: int, per_side: int
) -> None:
    """k x k copies of the square kilometre, each with the three depots where they stand in
    theirs: every copy launches its share of the aircraft (at most the capacity), no depot
    launches faster than the paper's, and every pad and site lies inside the larger area."""
    sized = TILED.sized(n_aircraft)
    assert sized.half_width_m == per_side * FAMILY.half_width_m
    assert len(sized.depots_enu_m) == 3 * per_side**2
    s = generate(BASE, n_aircraft, 3, TILED)
    assert len(s.aircraft) == n_aircraft
    copies = per_side**2
    depot_of = [sized.depots_enu_m.index(a_depot) for a_depot in _depots(s, sized)]
    copy_of = np.array(depot_of) % copies
    counts = np.bincount(copy_of, minlength=copies)
    assert counts.max() <= 16 and counts.max() - counts.min() <= 1
    for a, depot_index, copy in zip(s.aircraft, depot_of, copy_of, strict=True):
        depot = np.array(sized.depots_enu_m[depot_index])
        corner = np.array([copy % per_side, copy // per_side]) * 2 * FAMILY.half_width_m
        # the depot stands in its copy where an original depot stands in the original area
        in_copy = depot - (*corner, 0.0) + (sized.half_width_m - FAMILY.half_width_m)
        assert (*in_copy[:2], 0.0) in FAMILY.depots_enu_m
        assert np.hypot(*(np.array(a.start_enu_m) - depot)[:2]) <= 2 * FAMILY.pad_spacing_m + 1e-6
        assert all(abs(c) <= sized.half_width_m for c in (*a.start_enu_m[:2], *a.goal_enu_m[:2]))
        assert FAMILY.min_trip_m <= math.dist(a.start_enu_m[:2], a.goal_enu_m[:2])
    assert max(a.departure_s for a in s.aircraft) <= 20.0  # the paper's 16: 6 per depot, 4 s


def test_a_tile_capacity_below_one_is_refused() -> None:
    with pytest.raises(FieldValueError, match="tile_capacity"):
        FamilyConfig(tile_capacity=0)


def _depots(s: Scenario, family: FamilyConfig) -> list[tuple[float, float, float]]:
    """Each aircraft's depot: the family's depot nearest its pad."""
    depots = np.array(family.depots_enu_m)
    return [
        family.depots_enu_m[int(np.argmin(np.hypot(*(depots - a.start_enu_m)[:, :2].T)))]
        for a in s.aircraft
    ]
