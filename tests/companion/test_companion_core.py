"""The companion core against the real sim backend, wired through memory with MAVLink bytes.

``Flight`` is the h11-style pair: companions on one side, a ``SimBackend`` (companion
endpoints only) on the other, and a fake GCS link; every tick of 0.02 s each companion
handles what the sim sent on the previous tick, then the sim handles what the companions
sent. Hooks on both directions drop or rewrite datagrams.

Oracles: the sim's truth (``SimBackend.truth``) for where aircraft are; the free-space
equation re-derived here for RSSI; the scenario for serials and goals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import pytest

from ridsafe.common import codec, frames, topics
from ridsafe.common import messages as m
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import MemorySink
from ridsafe.common.scenario import AircraftConfig, RadioConfig, Scenario
from ridsafe.companion.companion import AUTOPILOT, GCS, Companion
from ridsafe.companion.config import CompanionConfig, CompanionSpec, OnArrival, StreamRatesHz
from ridsafe.companion.mission import Phase
from ridsafe.companion.planner_api import PlannerDecision, PlannerInput, PlannerStatus
from ridsafe.companion.planners import StraightLinePlanner
from ridsafe.sim_backend.config import SimConfig
from ridsafe.sim_backend.world import EndpointKind, SimBackend

ORIGIN = GeodeticOrigin(36.1447, -86.8027, 180.0)
DT_S = 0.02
GCS_SYSID = 250
SIGNING_KEY = bytes(range(32))

# Short legs keep a whole flight to ~30 s of sim time.
AIRCRAFT = (
    AircraftConfig("RSAF800000001", (0.0, 0.0, 0.0), (120.0, 80.0, 0.0), 25.0),
    AircraftConfig("RSAF800000002", (60.0, 0.0, 0.0), (-60.0, 120.0, 0.0), 30.0),
    AircraftConfig("RSAF800000003", (0.0, 90.0, 0.0), (100.0, -40.0, 0.0), 20.0),
)

Hook = Callable[[int, bytes], bytes | None]


def make_scenario(n_aircraft: int = 1) -> Scenario:
    return Scenario(ORIGIN, AIRCRAFT[:n_aircraft], None, RadioConfig(shadowing_sigma_db=0.0))


class RecordingPlanner:
    """The straight-line planner, keeping every input it was given."""

    name = "recording"

    def __init__(self) -> None:
        self.inner = StraightLinePlanner()
        self.inputs: list[PlannerInput] = []

    def plan(self, planner_input: PlannerInput) -> PlannerDecision:
        self.inputs.append(planner_input)
        return self.inner.plan(planner_input)


HOVER_ALT_TOLERANCE_M = 5.0
HOVERING = replace(CompanionConfig(), on_arrival=OnArrival.HOVER)  # stays where checked


class Flight:
    """Companions for the scenario's aircraft and the sim, routed in memory."""

    def __init__(
        self,
        scenario: Scenario,
        config: CompanionConfig | None = None,
        sim_config: SimConfig | None = None,
        signing: codec.SigningConfig | None = None,
    ) -> None:
        self.scenario = scenario
        self.config = config if config is not None else HOVERING
        self.sim = SimBackend(scenario, sim_config or SimConfig(), [EndpointKind.COMPANION])
        self.sinks: dict[int, MemorySink] = {}
        self.planners: dict[int, RecordingPlanner] = {}
        self.companions: dict[int, Companion] = {}
        for sysid in range(1, len(scenario.aircraft) + 1):
            self.sinks[sysid] = MemorySink()
            self.planners[sysid] = RecordingPlanner()
            spec = CompanionSpec.from_scenario(scenario, sysid)
            self.companions[sysid] = Companion(
                spec, self.config, self.planners[sysid], self.sinks[sysid], signing
            )
        self.gcs = codec.MavlinkLink(GCS_SYSID, 190, signing)
        self.to_companion: dict[int, list[tuple[str, bytes]]] = {i: [] for i in self.companions}
        self.from_companion_gcs: dict[int, list[bytes]] = {i: [] for i in self.companions}
        self.up: Hook = lambda sysid, data: data
        self.down: Hook = lambda sysid, data: data
        self.tick = 0
        self.t_s = 0.0
        self.truth: dict[int, np.ndarray] = {}  # tick -> (N, 3) true ENU positions

    def step(self) -> None:
        self.tick += 1
        self.t_s = round(self.tick * DT_S, 9)
        to_sim: list[tuple[str, bytes]] = []
        for sysid, companion in self.companions.items():
            inbound, self.to_companion[sysid] = self.to_companion[sysid], []
            for endpoint, data in companion.handle(self.t_s, inbound):
                if endpoint == GCS:
                    self.from_companion_gcs[sysid].append(data)
                    continue
                kept = self.up(sysid, data)
                if kept is not None:
                    to_sim.append((f"v{sysid}/companion", kept))
        for name, data in self.sim.handle(self.t_s, to_sim):
            sysid = int(name.split("/")[0][1:])
            kept = self.down(sysid, data)
            if kept is not None:
                self.to_companion[sysid].append((AUTOPILOT, kept))
        self.truth[self.tick] = self.sim.truth().p_enu_m.copy()

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT_S)):
            self.step()

    def run_until(self, done: Callable[[], bool], max_s: float) -> float:
        for _ in range(round(max_s / DT_S)):
            self.step()
            if done():
                return self.t_s
        raise AssertionError(f"not done after {max_s} s of sim time")

    def send_from_gcs(self, sysid: int, messages: Sequence[m.Message]) -> None:
        self.to_companion[sysid].append((GCS, self.gcs.pack_all(list(messages))))

    def gcs_received(self, sysid: int) -> list[codec.Received]:
        got: list[codec.Received] = []
        for data in self.from_companion_gcs[sysid]:
            got.extend(self.gcs.feed(data))
        self.from_companion_gcs[sysid] = []
        return got

    def events(self, sysid: int, name: str | None = None) -> list[dict[str, object]]:
        return [
            dict(r)
            for _, r in self.sinks[sysid].on(topics.COMPANION_EVENTS)
            if name is None or r["event"] == name
        ]

    def true_enu(self, t_s: float) -> np.ndarray:
        return self.truth[round(t_s / DT_S)]


def _local_truth(flight: Flight, sysid: int) -> np.ndarray:
    home = flight.sim.homes[sysid - 1]
    return home.enu_to_local_ned(flight.sim.truth().p_enu_m[sysid - 1])


def goal_enu(aircraft: AircraftConfig) -> np.ndarray:
    return np.array([aircraft.goal_enu_m[0], aircraft.goal_enu_m[1], aircraft.cruise_alt_m])


# --- flying --------------------------------------------------------------------------------


def test_companion_takes_off_flies_the_straight_line_and_arrives_within_the_radius() -> None:
    flight = Flight(make_scenario(1))
    companion = flight.companions[1]
    flight.run_until(lambda: companion.phase is Phase.DONE, max_s=60.0)

    true_p = flight.sim.truth().p_enu_m[0]
    goal = goal_enu(AIRCRAFT[0])
    assert math.hypot(*(true_p[:2] - goal[:2])) <= flight.config.arrival_radius_m
    assert abs(true_p[2] - goal[2]) <= HOVER_ALT_TOLERANCE_M  # HOVER holds the cruise level
    phases = [e["to"] for e in flight.events(1, "phase")]
    assert phases == [
        "request_streams",
        "wait_departure",
        "set_guided",
        "arm",
        "takeoff",
        "climb",
        "cruise",
        "arrived",
        "hover",
        "done",
    ]
    assert flight.events(1, "arrived")
    # straight line: every true position while cruising is near the start-goal segment
    start = np.array(AIRCRAFT[0].start_enu_m[:2])
    direction = (goal[:2] - start) / np.linalg.norm(goal[:2] - start)
    offsets = [p[0, :2] - start for p in flight.truth.values()]
    cross = [abs(direction[0] * d[1] - direction[1] * d[0]) for d in offsets]
    assert max(cross) < 3.0
    decisions = flight.sinks[1].on(topics.DECISIONS)
    assert decisions and all(r["planner"] == "recording" for _, r in decisions)
    for _, r in decisions:
        assert set(topics.TOPICS[topics.DECISIONS][1]) <= set(r)
        speed = math.hypot(*r["target_v_ned_m_s"])
        assert speed <= 8.0 + 1e-9


def test_decisions_log_the_target_as_geodetic_consistent_with_the_local_frame() -> None:
    flight = Flight(make_scenario(1))
    flight.run_until(lambda: len(flight.sinks[1].on(topics.DECISIONS)) >= 3, max_s=30.0)
    home = flight.sim.homes[0].home_geodetic
    for _, r in flight.sinks[1].on(topics.DECISIONS):
        back = frames.geodetic_to_ned(
            home, r["target_lat_deg"], r["target_lon_deg"], r["target_alt_m"]
        )
        np.testing.assert_allclose(back, r["target_p_ned_m"], atol=1e-6)


def test_setpoints_are_resent_at_the_replan_rate_so_the_velocity_failsafe_never_trips() -> None:
    flight = Flight(make_scenario(1))
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, max_s=20.0)
    flight.run(10.0)
    autopilot = flight.sim.autopilots[0]
    assert not autopilot.failsafe_active
    assert autopilot.rejected_targets == 0
    assert flight.sim.truth().p_enu_m[0, 2] > 12.0  # climbing towards 25 m while cruising
    times = [t for t, _ in flight.sinks[1].on(topics.DECISIONS)]
    gaps = np.diff(times)
    assert gaps.max() <= flight.config.replan_period_s + 1e-6


def test_land_on_arrival_descends_under_the_planner_then_lands_and_disarms() -> None:
    config = replace(CompanionConfig(), on_arrival=OnArrival.LAND)
    flight = Flight(make_scenario(1), config)
    flight.run_until(lambda: flight.companions[1].phase is Phase.DONE, max_s=150.0)
    assert not flight.sim.truth().armed[0]
    assert flight.sim.truth().p_enu_m[0, 2] < 0.5
    phases = [e["to"] for e in flight.events(1, "phase")]
    assert phases[-4:] == ["arrived", "descend", "land", "done"]
    # the planner flew the descent: its last targets before LAND were below cruise altitude
    descent = [p for p in flight.planners[1].inputs if p.goal_ned_m[2] > -1.0]
    assert descent, "the planner never saw the ground-level delivery point"


# --- Remote ID between aircraft ------------------------------------------------------------


def test_own_rid_reaches_the_other_companions_with_free_space_rssi() -> None:
    flight = Flight(make_scenario(3))
    flight.run(15.0)
    tx_power = flight.scenario.radio.tx_power_dbm
    for rx in (1, 2, 3):
        items = [i for _, r in flight.sinks[rx].on(topics.OBSERVATIONS) for i in r["items"]]
        for tx in (1, 2, 3):
            serial = AIRCRAFT[tx - 1].serial
            heard = [i for i in items if i["uas_id"] == serial]
            if tx == rx:
                assert not heard  # the radio never hands a transmitter its own frames
                continue
            assert len(heard) >= 13, (rx, tx, len(heard))
            for item in heard:
                truth = flight.true_enu(item["t_s"])
                distance = float(np.linalg.norm(truth[tx - 1] - truth[rx - 1]))
                expected = tx_power - 20 * math.log10(distance) - 20 * math.log10(2400) + 27.56
                assert abs(item["rssi_dbm"] - expected) < 1.0, (item, expected)


def test_observations_carry_the_receivers_own_position_at_the_receive_time() -> None:
    # GLOBAL_POSITION_INT at 2.7 Hz: receptions fall between fixes, up to 0.37 s (3 m) after
    config = replace(CompanionConfig(), streams_hz=StreamRatesHz(global_position_int=2.7))
    flight = Flight(make_scenario(2), config)
    flight.run(20.0)  # both cruising at up to 8 m/s
    items = [i for _, r in flight.sinks[1].on(topics.OBSERVATIONS) for i in r["items"]]
    assert len(items) >= 18
    for item in items:
        truth = flight.true_enu(item["t_s"])[0]
        rx = frames.geodetic_to_enu(
            ORIGIN, item["rx_lat_deg"], item["rx_lon_deg"], item["rx_alt_m"]
        )
        assert np.linalg.norm(rx - truth) < 0.5, (item["t_s"], rx, truth)
        claimed = frames.geodetic_to_enu(
            ORIGIN, item["claimed_lat_deg"], item["claimed_lon_deg"], item["claimed_alt_m"]
        )
        sender = flight.true_enu(item["t_s"])[1]
        assert np.linalg.norm(claimed - sender) < 1.5  # F3411 quantisation and 1 tick


def test_observations_reach_the_gcs_link_once_each_and_match_the_log() -> None:
    flight = Flight(make_scenario(2))
    flight.run(6.0)
    received = [r.message for r in flight.gcs_received(1)]
    observations = [
        o for r in received if isinstance(r, m.ObservationRows) for o in r.observations()
    ]
    assert all(len(r) <= 3 for r in received if isinstance(r, m.ObservationRows))  # packs
    logged = [i for _, r in flight.sinks[1].on(topics.OBSERVATIONS) for i in r["items"]]
    assert len(observations) == len(logged) >= 5
    assert [o.rid_timestamp_s for o in observations] == [i["rid_timestamp_s"] for i in logged]
    assert all(o.uas_id == AIRCRAFT[1].serial for o in observations)
    counters = flight.companions[1].counters_snapshot()
    assert counters["observations.sent_before_gcs_seen"] == len(observations)  # no GCS yet
    assert any(isinstance(r, m.Heartbeat) for r in received)


# --- regions, alerts and the planner ----------------------------------------------------------


def _region(uas_id: str, center_enu: tuple[float, float, float], t_s: float) -> m.UnsafeRegionMsg:
    lat, lon, alt = frames.enu_to_geodetic(ORIGIN, np.array(center_enu))
    return m.UnsafeRegionMsg(
        t_s, t_s + 2.0, float(lat), float(lon), float(alt),
        (100.0, 5.0, 0.0, 80.0, 0.0, 50.0), (1.0, 2.0, 0.0), 7.81, 0.05, 3, 0, uas_id,
    )  # fmt: skip


def test_regions_and_alerts_from_the_gcs_reach_the_planner_in_local_ned() -> None:
    flight = Flight(make_scenario(2), signing=codec.SigningConfig(SIGNING_KEY))
    flight.run_until(lambda: flight.companions[1].phase is Phase.CRUISE, max_s=20.0)
    t = flight.companions[1].sim_time(flight.t_s)
    alert = m.SpoofAlert(t, 30.0, 11.3, int(m.RidsafeDetector.NIS), 1, AIRCRAFT[1].serial)
    flight.send_from_gcs(1, [_region("RSAF800000666", (50.0, 40.0, 60.0), t), alert])
    flight.run(0.6)

    last = flight.planners[1].inputs[-1]
    (region,) = last.regions
    home = flight.sim.homes[0]
    expected = home.enu_to_local_ned(np.array([50.0, 40.0, 60.0]))
    np.testing.assert_allclose(region.center_ned_m, expected, atol=0.01)
    assert region.cov_ned_m2 == ((100.0, 5.0, 0.0), (5.0, 80.0, 0.0), (0.0, 0.0, 50.0))
    (neighbour,) = last.neighbours
    assert neighbour.uas_id == AIRCRAFT[1].serial and neighbour.flagged
    true_local = home.enu_to_local_ned(flight.true_enu(neighbour.t_s)[1])
    assert np.linalg.norm(np.subtract(neighbour.p_ned_m, true_local)) < 1.5
    assert [e["detail"] for e in flight.events(1, "region")] == ["RSAF800000666: new"]

    flight.run(2.5)  # valid for 2 s: gone
    assert flight.planners[1].inputs[-1].regions == ()
    assert [e["detail"] for e in flight.events(1, "region")][-1] == "RSAF800000666: expired"
    assert flight.companions[1].counters_snapshot()["regions.expired"] == 1


def test_unsigned_gcs_messages_are_rejected_when_signing_is_on() -> None:
    flight = Flight(make_scenario(1), signing=codec.SigningConfig(SIGNING_KEY))
    forger = codec.MavlinkLink(GCS_SYSID, 190)
    region = _region("RSAF800000666", (0.0, 0.0, 30.0), 0.5)
    flight.to_companion[1].append((GCS, forger.pack(region)))
    flight.run(1.0)
    companion = flight.companions[1]
    assert companion.regions.live(0.0) == []
    assert companion.counters_snapshot()["gcs.rejected_signature"] == 1


def test_a_planner_that_raises_is_logged_and_the_aircraft_holds_position() -> None:
    class Broken:
        name = "broken"

        def plan(self, planner_input: PlannerInput) -> PlannerDecision:
            if planner_input.t_s > 8.0:
                raise RuntimeError("boom")
            return StraightLinePlanner().plan(planner_input)

    flight = Flight(make_scenario(1))
    flight.companions[1].pilot.planner = Broken()
    flight.run(14.0)
    companion = flight.companions[1]
    assert companion.pilot.counters.planner_errors >= 8
    assert flight.events(1, "planner_error")
    assert companion.last_decision is not None
    assert companion.last_decision.status is PlannerStatus.STUCK
    v = flight.sim.truth().v_enu_m_s[0]
    assert np.linalg.norm(v) < 1.0  # held where it was


# --- faults ---------------------------------------------------------------------------------


def test_garbage_on_both_endpoints_is_counted_and_survived() -> None:
    rng = np.random.default_rng(7)
    flight = Flight(make_scenario(2))
    valid_tail = flight.gcs.pack(m.Heartbeat(6, 8, 0, 0, 4))
    for _ in range(round(3.0 / DT_S)):
        for sysid in flight.companions:
            junk = rng.integers(0, 256, int(rng.integers(1, 300)), dtype=np.uint8).tobytes()
            flight.to_companion[sysid].append((AUTOPILOT, junk))
            flight.to_companion[sysid].append((GCS, b"\xfd" + junk))
            flight.to_companion[sysid].append((GCS, junk[:10] + valid_tail))
            flight.to_companion[sysid].append(("nowhere", junk))
        flight.step()
    flight.run_until(lambda: all(c.phase is Phase.DONE for c in flight.companions.values()), 70.0)
    for sysid, companion in flight.companions.items():
        flight.to_companion[sysid].clear()
        companion.finish(flight.t_s + DT_S)
        (_, last), *_ = reversed(flight.sinks[sysid].on(topics.APP_COUNTERS))
        counters = last["counters"]
        assert last["app"] == f"companion/{sysid}"
        assert counters["autopilot.bad_data"] + counters["autopilot.truncated"] > 0
        assert counters["gcs.bad_data"] + counters["gcs.truncated"] > 0
        assert counters["companion.unknown_endpoint"] == 150
        assert flight.events(sysid, "gcs_seen")  # the valid heartbeat behind the junk


def test_counters_are_logged_every_10_s_and_at_the_end() -> None:
    flight = Flight(make_scenario(1))
    flight.run(25.0)
    flight.companions[1].finish(flight.t_s)
    times = [t for t, _ in flight.sinks[1].on(topics.APP_COUNTERS)]
    assert len(times) == 3
    assert times[0] == pytest.approx(10.0, abs=0.05)
    assert times[1] == pytest.approx(20.0, abs=0.05)


def test_an_autopilot_that_goes_silent_is_logged_and_its_return_too() -> None:
    flight = Flight(make_scenario(1))
    flight.run(8.0)
    flight.down = lambda sysid, data: None
    flight.run(5.0)
    assert [e["event"] for e in flight.events(1) if "autopilot_" in str(e["event"])][-1] == (
        "autopilot_lost"
    )
    assert flight.companions[1].emergency()  # silent while armed
    flight.down = lambda sysid, data: data
    flight.run(2.0)
    assert flight.events(1, "autopilot_regained")
    assert not flight.companions[1].emergency()


def test_time_must_not_go_backwards() -> None:
    flight = Flight(make_scenario(1))
    flight.run(0.1)
    with pytest.raises(ValueError, match="backwards"):
        flight.companions[1].handle(0.05, [])


# --- the straight-line planner ------------------------------------------------------------------


def _input(p: tuple[float, float, float], goal: tuple[float, float, float]) -> PlannerInput:
    return PlannerInput(0.0, p, (0.0, 0.0, 0.0), goal, (), ())


def test_straight_line_target_is_ahead_on_the_line_with_cruise_velocity() -> None:
    planner = StraightLinePlanner(cruise_speed_m_s=6.0, lookahead_s=1.5)
    decision = planner.plan(_input((0.0, 0.0, -10.0), (300.0, 400.0, -10.0)))
    assert decision.target_p_ned_m == pytest.approx((5.4, 7.2, -10.0))  # 9 m along (0.6, 0.8)
    assert decision.target_v_ned_m_s == pytest.approx((3.6, 4.8, 0.0))
    assert decision.status is PlannerStatus.CRUISE


def test_straight_line_holds_the_goal_position_only_inside_the_approach_radius() -> None:
    planner = StraightLinePlanner(approach_radius_m=15.0, arrival_radius_m=10.0)
    near = planner.plan(_input((0.0, 0.0, -30.0), (12.0, 0.0, -30.0)))
    assert near.target_p_ned_m == (12.0, 0.0, -30.0)
    assert near.target_v_ned_m_s == (0.0, 0.0, 0.0)
    assert near.status is PlannerStatus.CRUISE
    there = planner.plan(_input((0.0, 0.0, -30.0), (6.0, 8.0, -30.0)))
    assert there.status is PlannerStatus.ARRIVED


def test_straight_line_refuses_speeds_above_the_papers_limit() -> None:
    with pytest.raises(ValueError, match="cruise_speed_m_s"):
        StraightLinePlanner(cruise_speed_m_s=9.0)
