"""The jams of dense traffic, reproduced small (lockstep, no shadowing: deterministic).

- Depot: aircraft parked on the pads around a departing aircraft broadcast Remote ID from the
  ground, and the planner, taking them for traffic, crawls off its pad (at 64 aircraft a depot
  holds up to 21 parked aircraft; leaving took 17 s on average and up to 48 s, against 11 s
  alone). With ``companion.ignore_grounded_traffic`` they are left out and the delivery is on
  time.
- Parallel lanes: aircraft flying side by side 80 m apart are within the planner's d_safe of
  each other the whole way, push each other off their tracks and arrive up to 6 s late. With
  ``companion.traffic_gate`` (companion/traffic_gate.py) the planner sees only aircraft on a
  collision course or near, and all arrive together, on time.
- Crowded delivery sites: four aircraft converge on four sites 31-44 m apart. They reach
  their sites at different heights, having climbed or sunk around each other; when arriving
  also asked for the cruise altitude (``companion.arrival_alt_tolerance_m``), an aircraft
  over its site first flew back to that level among the others before descending, and the
  last delivery came half a minute later than when the descent starts from where it is.
  Approaching the site at the cruise level (not at the aircraft's own height) still held the
  last delivery back by a quarter of a minute.
- Landings beside landings: four aircraft descend to four sites 76-80 m apart. Over its
  site but beyond the approach radius in 3-D (the goal on the ground 50-70 m below), an
  aircraft chose among held actions and, keeping d_safe from the one landing next door,
  flew off its site; one never came back to land. Descending straight onto the goal while
  hovering there stays clear and nobody is near the column down (``planner.approach_descent``),
  all four land.
- A landing beside a delivered aircraft: an aircraft comes to a site 40 m from one where
  another has just landed. Pushed off its site while that one was still coming down, it held
  the planner's d_safe (100 m) from it once it stood on the ground, 50 m off its own site,
  to the end of the run. In the descent the aircraft standing on the ground are no traffic
  (``companion.landing_ignores_grounded_traffic``): it comes back and lands.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import pytest

from ridsafe.common.config import load_config
from ridsafe.companion.traffic_gate import TrafficGate
from ridsafe.tools.analysis.deliveries import deliveries
from ridsafe.tools.analysis.metrics import arrival_times_s
from ridsafe.tools.analysis.run_arrays import RunLog, load_run
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import ScenarioFile

DEPOT_JAM = Path(__file__).with_name("depot_jam.yaml")
PARALLEL_LANES = Path(__file__).with_name("parallel_lanes.yaml")
DELIVERY_CLUSTER = Path(__file__).with_name("delivery_cluster.yaml")
LANDING_SITES = Path(__file__).with_name("landing_sites.yaml")
LANDED_BESIDE = Path(__file__).with_name("landed_beside.yaml")
NOMINAL_ARRIVAL_S = 4.0 + 300.0 / 8.0  # take-off, then 300 m at 8 m/s


def _fly(
    tmp_path: Path, scenario: Path, planner: dict[str, Any] | None = None, **companion: Any
) -> RunLog:
    """Fly ``scenario`` (aware, lockstep) with these companion (and ``planner``) settings."""
    loaded = load_config(scenario, ScenarioFile)
    changed = dataclasses.replace(loaded.companion, **companion)
    planner_config = dataclasses.replace(loaded.planner, **(planner or {}))
    loaded = dataclasses.replace(loaded, companion=changed, planner=planner_config)
    out = tmp_path / f"{scenario.stem}-{len(list(tmp_path.iterdir()))}.mcap"
    run_lockstep(loaded, "aware", out, recorder_process=False)
    return load_run(out)


def _arrivals_s(
    tmp_path: Path, scenario: Path, planner: dict[str, Any] | None = None, **companion: Any
) -> dict[int, float]:
    """Each benign aircraft's arrival time (s; inf when it never arrived), as ``_fly``."""
    run = _fly(tmp_path, scenario, planner, **companion)
    arrivals = arrival_times_s(run)
    return {s: math.inf if (t := arrivals.get(s)) is None else t for s in run.goals_enu_m}


@pytest.mark.slow
def test_parked_aircraft_jam_the_departure_unless_left_out(tmp_path: Path) -> None:
    jammed = _arrivals_s(tmp_path, DEPOT_JAM, ignore_grounded_traffic=False)[1]
    free = _arrivals_s(tmp_path, DEPOT_JAM, ignore_grounded_traffic=True)[1]
    assert free <= NOMINAL_ARRIVAL_S + 6.0
    assert jammed >= free + 5.0  # today: 53.7 s against 45.4 s


@pytest.mark.slow
def test_parallel_lanes_jam_unless_the_gate_hands_only_conflicts(tmp_path: Path) -> None:
    nominal_s = 4.0 + 450.0 / 8.0
    jammed = _arrivals_s(tmp_path, PARALLEL_LANES, traffic_gate=TrafficGate()).values()
    gated = _arrivals_s(tmp_path, PARALLEL_LANES, traffic_gate=TrafficGate(min_airborne=2))
    assert all(t <= nominal_s + 6.0 for t in gated.values())
    assert max(jammed) >= max(gated.values()) + 4.0  # today: 71.1 s against 65.2 s


@pytest.mark.slow
def test_crowded_sites_deliver_sooner_when_the_descent_starts_at_any_height(
    tmp_path: Path,
) -> None:
    at_cruise_level = _arrivals_s(tmp_path, DELIVERY_CLUSTER, arrival_alt_tolerance_m=5.0)
    at_any_height = _arrivals_s(tmp_path, DELIVERY_CLUSTER)  # the default
    assert all(math.isfinite(t) for t in at_any_height.values())
    latest_s = max(at_any_height.values())
    assert latest_s <= max(at_cruise_level.values()) - 15.0  # today: 74.7 s against never


@pytest.mark.slow
def test_crowded_sites_deliver_sooner_when_the_approach_keeps_its_height(
    tmp_path: Path,
) -> None:
    """Arrived over the site at any height, an aircraft that reached it above or below its
    cruise level used to brake onto its site *at* that level, climbing or sinking among the
    others first; approaching at its own height it arrives there (``approach_level``).
    (73.7 s against 88.1 s before the descent could go straight onto a clear site.)"""
    at_cruise_level = _arrivals_s(tmp_path, DELIVERY_CLUSTER, {"approach_level": False})
    at_own_height = _arrivals_s(tmp_path, DELIVERY_CLUSTER)  # the default
    assert all(math.isfinite(t) for t in at_own_height.values())
    latest_s = max(at_own_height.values())
    assert latest_s <= max(at_cruise_level.values()) - 8.0  # today: 74.7 s against 91.2 s


@pytest.mark.slow
def test_landings_beside_landings_descend_straight_onto_their_sites(tmp_path: Path) -> None:
    def landed_s(planner: dict[str, Any]) -> dict[int, float]:
        rows = deliveries(_fly(tmp_path, LANDING_SITES, planner))
        return {r.sysid: math.inf if r.landed_s is None else r.landed_s for r in rows}

    drifting = landed_s({"approach_descent": False})
    straight = landed_s({})  # the default
    assert all(math.isfinite(t) for t in straight.values())  # today: 85.0-110.2 s
    assert not all(math.isfinite(t) for t in drifting.values())  # today: aircraft 2 never


@pytest.mark.slow
def test_a_landing_beside_a_delivered_aircraft_is_not_held_off_by_it(tmp_path: Path) -> None:
    def landed_s(**companion: Any) -> dict[int, float]:
        rows = deliveries(_fly(tmp_path, LANDED_BESIDE, None, **companion))
        return {r.sysid: math.inf if r.landed_s is None else r.landed_s for r in rows}

    held_off = landed_s(landing_ignores_grounded_traffic=False)
    lands = landed_s()  # the default
    assert held_off[1] == lands[1] < 60.0  # the first lands alone: today 58.0 s both times
    assert math.isfinite(lands[2])  # today: 113.6 s
    assert held_off[2] == math.inf  # today: 50.7 m off its site at the end
