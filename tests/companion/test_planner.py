"""The aware and trust-rid planners: decisions in single scenes and in scripted closed loops."""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from ridsafe.companion.actions import ActionSet, build_action_set, heading_to_rad, rollout
from ridsafe.companion.planner import (
    AwarePlanner,
    FastMdpPlanner,
    ProgressWatchdog,
    TrustRidPlanner,
    choose_action,
)
from ridsafe.companion.planner_api import (
    Neighbour,
    PlannerDecision,
    PlannerInput,
    PlannerStatus,
    Region,
    Vec3,
)
from ridsafe.companion.planner_config import GRAVITY_M_S2, ArrivalAction, PlannerConfig
from ridsafe.companion.planner_eval import (
    KernelParams,
    RolloutScores,
    build_scene,
    score_actions,
)
from ridsafe.companion.planners import PlannerSettings, make_planner
from ridsafe.companion.value import region_distance_m
from ridsafe.tools.planner_loop.scripted import ScriptedSpoofer, fly

CHI2_95 = 7.814727903251178
CRUISE: Vec3 = (0.0, 0.0, -60.0)
COV_20M = ((400.0, 0.0, 0.0), (0.0, 400.0, 0.0), (0.0, 0.0, 1600.0))
PLANNERS: list[Callable[..., FastMdpPlanner]] = [AwarePlanner, TrustRidPlanner]
FloatArray = NDArray[np.float64]


def _inp(
    p: Vec3 = CRUISE,
    goal: Vec3 = (600.0, 0.0, -60.0),
    v: Vec3 = (0.0, 0.0, 0.0),
    neighbours: tuple[Neighbour, ...] = (),
    regions: tuple[Region, ...] = (),
    t_s: float = 10.0,
) -> PlannerInput:
    return PlannerInput(t_s, p, v, goal, neighbours, regions)


def _step(decision: PlannerDecision, p: Vec3 = CRUISE) -> FloatArray:
    step: FloatArray = np.asarray(decision.target_p_ned_m) - np.asarray(p)
    return step


def _region(center: Vec3, t_s: float = 10.0) -> Region:
    return Region("SPOOF", center, COV_20M, CHI2_95, (0.0, 0.0, 0.0), t_s, t_s + 1.0)


@pytest.mark.parametrize("make", PLANNERS)
@pytest.mark.parametrize(
    "goal", [(600.0, 0.0, -60.0), (-300.0, 400.0, -60.0), (0.0, -500.0, -80.0)]
)
@pytest.mark.parametrize("v0", [(0.0, 0.0, 0.0), (2.0, -1.0, 0.0)])
def test_free_space_moves_toward_the_goal(
    make: Callable[..., FastMdpPlanner], goal: Vec3, v0: Vec3
) -> None:
    """The commanded velocity change points at the goal (the setpoint is on the ramp from v0)."""
    decision = make().plan(_inp(goal=goal, v=v0))
    to_goal = np.asarray(goal) - np.asarray(CRUISE)
    to_goal /= np.linalg.norm(to_goal)
    dv = np.asarray(decision.target_v_ned_m_s) - np.asarray(v0)
    assert decision.status is PlannerStatus.CRUISE
    assert float(np.dot(dv, to_goal)) > 0.95 * float(np.linalg.norm(dv)) > 0.0
    pushed = _step(decision) - np.asarray(v0) * PlannerConfig().target_lead_s  # a u L^2 / 2
    assert float(np.dot(pushed, to_goal)) > 0.95 * float(np.linalg.norm(pushed)) > 0.0


def test_decisions_are_deterministic() -> None:
    inp = _inp(
        neighbours=(Neighbour("A", (150.0, 10.0, -60.0), (-8.0, 0.0, 0.0), 9.5, False),),
        regions=(_region((300.0, -40.0, -60.0)),),
    )
    a, b = AwarePlanner().plan(inp), AwarePlanner().plan(inp)
    assert a == b


def test_head_on_pair_separates_beyond_the_nmac_radius() -> None:
    """Two planners on exactly reciprocal tracks (a symmetric tie): both turn right and pass."""
    start_a, start_b = (0.0, 0.0, -60.0), (600.0, 0.0, -60.0)
    encounter = fly([AwarePlanner(), AwarePlanner()], [start_a, start_b], [start_b, start_a], 100.0)
    assert encounter.min_separation_m() > 50.0
    np.testing.assert_allclose(encounter.p_ned_m[-1], [start_b, start_a], atol=10.0)  # arrived


def test_crossing_traffic_separates() -> None:
    starts: list[Vec3] = [(0.0, 0.0, -60.0), (300.0, -300.0, -55.0), (300.0, 300.0, -65.0)]
    goals: list[Vec3] = [(600.0, 0.0, -60.0), (300.0, 300.0, -55.0), (300.0, -300.0, -65.0)]
    encounter = fly([TrustRidPlanner() for _ in starts], starts, goals, 60.0)
    assert encounter.min_separation_m() > 50.0


def _scores_for(inp: PlannerInput, cfg: PlannerConfig) -> tuple[ActionSet, RolloutScores]:
    p0, v0, goal = (np.asarray(x) for x in (inp.p_ned_m, inp.v_ned_m_s, inp.goal_ned_m))
    actions = build_action_set(cfg, heading_to_rad(p0, goal))
    scene = build_scene(inp.t_s, p0, inp.neighbours, inp.regions, cfg)
    return actions, score_actions(p0, v0, goal, actions, scene, KernelParams.from_config(cfg))


def test_a_rollout_through_the_ellipsoid_is_never_chosen_when_a_safe_one_exists() -> None:
    """With a negligible region reward and no extension the value alone would fly straight
    through; the shield picks a rollout that stays clear, and the setpoint follows it."""
    cfg = PlannerConfig(region_reward=-1e-9, extension_samples=0)
    region = _region((130.0, 5.0, -60.0))
    inp = _inp(v=(6.0, 0.0, 0.0), regions=(region,))
    actions, scores = _scores_for(inp, cfg)
    index, status, _ = choose_action(scores, actions, cfg)
    best_value = int(np.argmax(scores.goal + scores.hazard))
    assert scores.intrusion_m[best_value] > 0.0
    assert scores.intrusion_m[index] == 0.0 and status is PlannerStatus.AVOIDING
    tau = np.asarray(cfg.sample_times_s)
    path, _ = rollout(
        inp.p_ned_m, inp.v_ned_m_s, actions.velocity_ned_m_s[index], tau, cfg.accel_m_s2
    )
    d = [
        region_distance_m(
            path[k], region.center_ned_m, np.asarray(COV_20M) + (t**2) * np.eye(3), CHI2_95
        )
        for k, t in enumerate(tau)
    ]
    assert min(d) >= cfg.region_margin_m
    decision = AwarePlanner(cfg).plan(inp)
    assert decision.status is PlannerStatus.AVOIDING
    assert (
        float(region_distance_m(decision.target_p_ned_m, region.center_ned_m, COV_20M, CHI2_95))
        > 0.0
    )


@settings(max_examples=30, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.floats(-math.pi, math.pi),
    st.floats(40.0, 250.0),
    st.floats(0.0, 8.0),
    st.floats(-math.pi, math.pi),
)
def test_shield_holds_in_random_scenes(
    bearing: float, dist: float, speed: float, course: float
) -> None:
    cfg = PlannerConfig()
    center: Vec3 = (dist * math.cos(bearing), dist * math.sin(bearing), -60.0)
    v: Vec3 = (speed * math.cos(course), speed * math.sin(course), 0.0)
    region = Region("S", center, COV_20M, CHI2_95, (-3.0, 4.0, 0.0), 10.0, 11.0)
    actions, scores = _scores_for(_inp(v=v, regions=(region,)), cfg)
    index, status, _ = choose_action(scores, actions, cfg)
    if np.any(scores.envelope_ok & (scores.intrusion_m == 0.0)):
        assert scores.intrusion_m[index] == 0.0 and status is not PlannerStatus.NO_SAFE_ACTION
    else:
        assert status is PlannerStatus.NO_SAFE_ACTION


def test_inside_the_ellipsoid_the_fallback_leaves_it() -> None:
    center: Vec3 = (20.0, 10.0, -60.0)
    decision = AwarePlanner().plan(_inp(v=(3.0, 0.0, 0.0), regions=(_region(center),)))
    assert decision.status is PlannerStatus.NO_SAFE_ACTION
    away = np.asarray(CRUISE) - np.asarray(center)
    assert float(np.dot(decision.target_v_ned_m_s, away)) > float(np.dot((3.0, 0.0, 0.0), away))
    # flown closed loop, it is outside the ellipsoid within seconds
    spoofer = ScriptedSpoofer(center, cov_ned_m2=(400.0, 400.0, 1600.0))
    track = fly([AwarePlanner()], [CRUISE], [(600.0, 0.0, -60.0)], 15.0, spoofer).p_ned_m[:, 0]
    d = region_distance_m(track, center, COV_20M, CHI2_95)
    out = int(np.argmax(d > 0.0))
    assert 0 < out < 0.5 * len(d) and np.all(d[out:] > 0.0)  # out within 7 s, never back in


def test_deep_inside_a_region_the_fallback_heads_out_not_on_to_the_goal() -> None:
    # 50 m sigma: 140 m to the surface, no rollout (10 s at <= 8 m/s) gets out, so what
    # tells the actions apart is how deep inside their samples are
    cov = ((2500.0, 0.0, 0.0), (0.0, 2500.0, 0.0), (0.0, 0.0, 2500.0))
    center: Vec3 = (30.0, 0.0, -60.0)  # ahead, between the aircraft and its goal
    region = Region("SPOOF", center, cov, CHI2_95, (0.0, 0.0, 0.0), 10.0, 11.0)
    decision = AwarePlanner().plan(_inp(v=(2.0, 0.0, 0.0), regions=(region,)))
    assert decision.status is PlannerStatus.NO_SAFE_ACTION
    away = np.asarray(CRUISE) - np.asarray(center)
    away /= np.linalg.norm(away)
    v_away = float(np.dot(decision.target_v_ned_m_s, away))
    assert v_away > 0.0  # turned back, from +2 m/s toward the centre


def test_aware_ignores_flagged_rid_and_trust_rid_avoids_it() -> None:
    liar = Neighbour("SPOOF", (120.0, 0.0, -60.0), (0.0, 0.0, 0.0), 9.8, True)
    aware, trust = (
        AwarePlanner().plan(_inp(neighbours=(liar,))),
        TrustRidPlanner().plan(_inp(neighbours=(liar,))),
    )
    assert aware.status is PlannerStatus.CRUISE and "0 aircraft" in aware.detail
    assert trust.status is PlannerStatus.AVOIDING and "1 aircraft" in trust.detail


def test_aware_also_distrusts_an_unflagged_id_that_has_a_region() -> None:
    liar = Neighbour("SPOOF", (120.0, 0.0, -60.0), (0.0, 0.0, 0.0), 9.8, False)
    decision = AwarePlanner().plan(
        _inp(neighbours=(liar,), regions=(_region((300.0, -300.0, -60.0)),))
    )
    assert "0 aircraft" in decision.detail


def test_trust_rid_ignores_regions() -> None:
    inp = _inp(regions=(_region((100.0, 0.0, -60.0)),))
    assert TrustRidPlanner().plan(inp).status is PlannerStatus.CRUISE
    assert AwarePlanner().plan(inp).status is PlannerStatus.AVOIDING


def test_stale_rid_is_ignored() -> None:
    old = Neighbour("A", (100.0, 0.0, -60.0), (0.0, 0.0, 0.0), 10.0 - 6.0, False)
    assert "0 aircraft" in TrustRidPlanner().plan(_inp(neighbours=(old,))).detail


@pytest.mark.parametrize("y_m", [-20.0, -40.0])
def test_trust_rid_avoids_the_claim_into_the_spoofer_and_aware_avoids_the_spoofer(
    y_m: float,
) -> None:
    """The spoofer hovers just west of the track and claims to be 50 m north-east of itself, just
    east of the track. Trust-RID keeps clear of the claim by passing west, into the spoofer;
    aware keeps clear of the ellipsoid around the truth."""
    spoofer = ScriptedSpoofer((350.0, y_m, -60.0))
    claim = np.asarray(spoofer.start_ned_m) + np.asarray(spoofer.offset_ned_m)
    goal: Vec3 = (700.0, 0.0, -60.0)
    trust = fly([TrustRidPlanner()], [CRUISE], [goal], 110.0, spoofer)
    aware = fly([AwarePlanner()], [CRUISE], [goal], 110.0, spoofer)
    trust_claim = float(np.linalg.norm(trust.p_ned_m[:, 0] - claim, axis=1).min())
    assert trust.min_spoofer_distance_m() < 50.0 < trust_claim
    assert aware.min_spoofer_distance_m() > 50.0
    inside = region_distance_m(aware.p_ned_m[:, 0], spoofer.start_ned_m, COV_20M, CHI2_95)
    assert np.all(inside > 0.0)
    np.testing.assert_allclose(aware.p_ned_m[-1, 0], goal, atol=25.0)


def test_arrival_hovers_or_lands_and_latches() -> None:
    goal: Vec3 = (100.0, 50.0, -60.0)
    hover = AwarePlanner()
    d = hover.plan(_inp(p=(95.0, 50.0, -60.0), goal=goal))
    assert (
        d.status is PlannerStatus.ARRIVED
        and d.target_p_ned_m == goal
        and d.target_v_ned_m_s == (0.0, 0.0, 0.0)
    )
    assert hover.plan(_inp(p=(80.0, 50.0, -60.0), goal=goal)).status is PlannerStatus.ARRIVED
    land = AwarePlanner(PlannerConfig(on_arrival=ArrivalAction.LAND, ground_down_m=2.0))
    assert land.plan(_inp(p=(95.0, 50.0, -60.0), goal=goal)).target_p_ned_m == (100.0, 50.0, 2.0)


def test_an_arrived_aircraft_evades_a_region_that_reaches_it() -> None:
    planner = AwarePlanner()
    goal: Vec3 = (100.0, 50.0, -60.0)
    assert planner.plan(_inp(p=goal, goal=goal)).status is PlannerStatus.ARRIVED
    decision = planner.plan(_inp(p=goal, goal=goal, regions=(_region((110.0, 50.0, -60.0)),)))
    assert decision.status is PlannerStatus.NO_SAFE_ACTION


def test_approach_targets_the_goal_when_unhindered() -> None:
    goal: Vec3 = (130.0, 0.0, -60.0)
    d = TrustRidPlanner().plan(_inp(p=(100.0, 0.0, -60.0), goal=goal, v=(6.0, 0.0, 0.0)))
    assert d.status is PlannerStatus.CRUISE and d.target_p_ned_m == goal


def test_an_aircraft_high_over_its_site_approaches_it_at_its_own_height() -> None:
    """Reached at any height, the goal is approached level: 40 m above its cruise level and
    15 m from its site, with an aircraft landing beside the site 60 m below, the aircraft
    brakes onto the point over the site. Asked for the goal itself it is 43 m away, beyond
    the approach radius, and sinking onto it would close on the one landing."""
    goal: Vec3 = (115.0, 0.0, -60.0)
    here: Vec3 = (100.0, 0.0, -100.0)
    landing = Neighbour("LANDING", (110.0, 10.0, -40.0), (0.0, 0.0, 1.5), 10.0, False)
    at_cruise = _inp(p=here, goal=goal, neighbours=(landing,))
    at_any_height = dataclasses.replace(at_cruise, goal_any_height=True)
    level = AwarePlanner().plan(at_any_height)
    assert level.detail == "approach over the goal"
    assert level.target_p_ned_m == (115.0, 0.0, -100.0)
    assert level.target_v_ned_m_s == (0.0, 0.0, 0.0)
    for planner, inp in (
        (AwarePlanner(), at_cruise),
        (AwarePlanner(PlannerConfig(approach_level=False)), at_any_height),
    ):
        decision = planner.plan(inp)
        assert not decision.detail.startswith("approach")
        assert decision.target_p_ned_m != (115.0, 0.0, -100.0)


def test_an_aircraft_over_its_site_descends_straight_onto_it_beside_traffic() -> None:
    """Descending to deliver (the goal on the ground), 65 m up and 8 m from its site, beside
    an aircraft landing at a site 80 m away: hovering here keeps 80 m from it (clear of the
    approach's 60 m), so the setpoint is the goal itself and the autopilot descends onto it.
    Measured in 3-D the goal is 65 m off, beyond the approach radius: the planner chose among
    held actions and, the other within its 100 m d_safe, flew off the site (at 64 aircraft,
    30-60 m off, some never coming back: docs/results/dense_traffic.md)."""
    goal: Vec3 = (100.0, 0.0, 0.0)
    here: Vec3 = (92.0, 0.0, -65.0)
    landing = Neighbour("LANDING", (100.0, 80.0, -60.0), (0.0, 0.0, 1.5), 10.0, False)
    descending = dataclasses.replace(
        _inp(p=here, goal=goal, neighbours=(landing,)), descend_to_goal=True
    )
    decision = AwarePlanner().plan(descending)
    assert decision.detail == "descend onto the goal"
    assert decision.status is PlannerStatus.AVOIDING  # the other is within d_safe
    assert decision.target_p_ned_m == goal
    assert decision.target_v_ned_m_s == (0.0, 0.0, 0.0)
    for planner, inp in (
        (AwarePlanner(), dataclasses.replace(descending, descend_to_goal=False)),
        (AwarePlanner(PlannerConfig(approach_descent=False)), descending),
    ):
        held = planner.plan(inp)
        assert not held.detail.startswith("descend onto")
        # the held action leaves the site, away from the one landing
        v_north, v_east, _ = held.target_v_ned_m_s
        assert math.hypot(v_north, v_east) > 1.0 and v_east < 0.0


def test_no_straight_descent_past_an_aircraft_beside_the_column() -> None:
    """30 m from its site, an aircraft 80 m from it but 50 m from the column it would descend
    (the other landing at a site beside this one): hovering here keeps 80 m, descending onto
    the site would pass it at 50 m, so the descent is no approach but the planner's choice."""
    goal: Vec3 = (100.0, 0.0, 0.0)
    here: Vec3 = (70.0, 0.0, -65.0)
    beside = Neighbour("BESIDE", (150.0, 0.0, -60.0), (0.0, 0.0, 0.0), 10.0, False)
    inp = dataclasses.replace(_inp(p=here, goal=goal, neighbours=(beside,)), descend_to_goal=True)
    decision = AwarePlanner().plan(inp)
    assert decision.detail != "descend onto the goal"
    assert decision.target_p_ned_m != goal
    clear = dataclasses.replace(
        inp, neighbours=(dataclasses.replace(beside, p_ned_m=(170.0, 0.0, -60.0)),)
    )
    assert AwarePlanner().plan(clear).detail == "descend onto the goal"  # 70 m from the column


def test_watchdog_reports_and_logs_lack_of_progress(caplog: pytest.LogCaptureFixture) -> None:
    dog = ProgressWatchdog(after_s=30.0, progress_m=10.0)
    goal = (100.0, 0.0, -50.0)
    with caplog.at_level(logging.WARNING, logger="ridsafe.companion.planner"):
        assert not dog.update(0.0, goal, 500.0)
        assert not dog.update(20.0, goal, 480.0)  # progress: the clock restarts
        assert not dog.update(45.0, goal, 475.0)  # 5 m is not progress, but only 25 s
        assert dog.update(50.0, goal, 476.0)
        assert dog.update(55.0, goal, 476.0)
    assert len([r for r in caplog.records if "no progress" in r.message]) == 1
    assert not dog.update(56.0, goal, 460.0)


def test_watchdog_counts_afresh_for_a_new_goal() -> None:
    """Over its site the aircraft's goal becomes the ground under it, 50 m further than the
    best it came to the point over it: a descent is not a lack of progress."""
    dog = ProgressWatchdog(after_s=30.0, progress_m=10.0)
    over_site, ground = (100.0, 0.0, -50.0), (100.0, 0.0, 0.0)
    assert not dog.update(0.0, over_site, 400.0)
    assert not dog.update(50.0, over_site, 5.0)
    assert not dog.update(51.0, ground, 55.0)
    assert not dog.update(80.0, ground, 50.0)  # 5 m in 29 s: not yet 30 s without progress
    assert dog.update(81.0, ground, 50.0)  # 30 s since the new goal's first distance
    assert not dog.update(82.0, ground, 40.0)


def test_a_planner_that_goes_nowhere_says_stuck() -> None:
    planner = TrustRidPlanner()
    statuses = [planner.plan(_inp(t_s=t)).status for t in np.arange(0.0, 31.0, 0.5)]
    assert statuses[0] is PlannerStatus.CRUISE and statuses[-1] is PlannerStatus.STUCK


@pytest.mark.parametrize("name", ["aware", "trust-rid"])
def test_a_companions_planner_names_its_aircraft_when_stuck(
    name: str, caplog: pytest.LogCaptureFixture
) -> None:
    """A lockstep run's 64 companions share one log: a stuck planner says which it is."""
    planner = make_planner(name, PlannerSettings(sysid=7))
    with caplog.at_level(logging.WARNING, logger="ridsafe.companion.planner"):
        for t in np.arange(0.0, 31.0, 0.5):
            planner.plan(_inp(t_s=t))
    (stuck,) = [r.getMessage() for r in caplog.records if "no progress" in r.getMessage()]
    assert stuck.startswith("aircraft 7: no progress toward the goal for 30 s")


VEC = st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0), st.floats(-1.5, 1.5))


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.tuples(st.floats(-500, 500), st.floats(-500, 500), st.floats(-110, -2)),
    VEC,
    st.tuples(st.floats(-500, 500), st.floats(-500, 500), st.floats(-100, -20)),
    st.lists(st.tuples(st.floats(-150, 150), st.floats(-150, 150), st.floats(-20, 20)), max_size=6),
    st.booleans(),
    st.sampled_from(PLANNERS),
)
def test_every_target_is_inside_the_flight_envelope(
    p: Vec3,
    v: Vec3,
    goal: Vec3,
    offsets: list[Vec3],
    with_region: bool,
    make: Callable[..., FastMdpPlanner],
) -> None:
    cfg = PlannerConfig()
    if np.linalg.norm(v) > cfg.max_speed_m_s:
        v = tuple(float(x) * cfg.max_speed_m_s / float(np.linalg.norm(v)) for x in v)  # type: ignore[assignment]
    neighbours = tuple(
        Neighbour(f"N{i}", (p[0] + o[0], p[1] + o[1], p[2] + o[2]), (-v[0], v[1], 0.0), 9.5, i == 0)
        for i, o in enumerate(offsets)
    )
    regions = (_region((p[0] + 80.0, p[1], p[2])),) if with_region else ()
    decision = make(cfg).plan(_inp(p=p, v=v, goal=goal, neighbours=neighbours, regions=regions))
    vt = np.asarray(decision.target_v_ned_m_s)
    assert np.all(np.isfinite(decision.target_p_ned_m)) and np.all(np.isfinite(vt))
    assert np.linalg.norm(vt) <= cfg.max_speed_m_s + 1e-9
    assert -cfg.max_climb_m_s - 1e-9 <= vt[2] <= cfg.max_descent_m_s + 1e-9
    if decision.status is not PlannerStatus.ARRIVED and decision.detail != "approach the goal":
        # the velocity step the cascade must make in about a second: a tilt within limits
        step = float(np.linalg.norm(vt - np.asarray(v))) / cfg.velocity_lead_s
        assert (
            step <= cfg.accel_m_s2 + 1e-9 <= GRAVITY_M_S2 * math.tan(math.radians(cfg.max_tilt_deg))
        )
        lead = float(np.linalg.norm(_step(decision, p)))
        assert lead <= cfg.max_speed_m_s * cfg.target_lead_s + 1e-9


def test_warm_up_leaves_the_planner_memory_alone() -> None:
    planner = AwarePlanner()
    planner.warm_up()
    assert not planner.arrived and planner.plan(_inp()).status is PlannerStatus.CRUISE


def test_the_extension_lets_a_spoofer_running_alongside_pass() -> None:
    """A spoofer flies east at 7 m/s just ahead of an aircraft whose goal is to the north-east.
    Without the extension the planner races it eastward (the goal term sees only 10 s ahead)
    and never gets round; with it, it lets the region pass and crosses behind."""
    spoofer = ScriptedSpoofer((100.0, -60.0, -60.0), (0.0, 7.0, 0.0))
    goal: Vec3 = (350.0, 250.0, -60.0)

    def arrived(cfg: PlannerConfig) -> bool:
        track = fly([AwarePlanner(cfg)], [CRUISE], [goal], 100.0, spoofer).p_ned_m[:, 0]
        return bool(np.any(np.linalg.norm(track - np.asarray(goal), axis=1) < 10.0))

    assert arrived(PlannerConfig())
    assert not arrived(PlannerConfig(extension_samples=0))


def test_non_finite_hazards_are_dropped() -> None:
    nan = float("nan")
    bad_rid = Neighbour("A", (nan, 0.0, -60.0), (0.0, 0.0, 0.0), 9.9, False)
    bad_region = Region(
        "S", (100.0, 0.0, -60.0), ((nan, 0, 0), (0, 1, 0), (0, 0, 1)), CHI2_95, (0, 0, 0), 9.9, 11.0
    )
    decision = AwarePlanner().plan(_inp(neighbours=(bad_rid,), regions=(bad_region,)))
    assert decision.status is PlannerStatus.CRUISE and np.all(np.isfinite(decision.target_p_ned_m))


def test_traffic_a_layer_above_is_no_conflict_with_a_vertical_weight() -> None:
    """A neighbour hovering 55 m overhead: within d_safe (100 m) of a hover at cruise, so a
    conflict for the paper's Euclidean term; with the benign term's vertical weight 2 it counts
    as 110 m away, no conflict, while the separation stays the true 55 m."""
    above = Neighbour("ABOVE", (0.0, 0.0, -115.0), (0.0, 0.0, 0.0), 10.0, False)
    inp = _inp(neighbours=(above,))
    hover = -1
    _, euclidean = _scores_for(inp, PlannerConfig())
    _, layered = _scores_for(inp, PlannerConfig(benign_vertical_weight=2.0))
    assert euclidean.hazard[hover] < 0.0
    assert layered.hazard[hover] == 0.0
    assert layered.min_separation_m[hover] == pytest.approx(55.0)
