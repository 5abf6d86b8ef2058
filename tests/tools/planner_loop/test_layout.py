"""The planner-only closed loop's world: the seeded layout keeps its promises, and the
kinematic aircraft fly the autopilot's limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ridsafe.sim_backend.params import ControllerParams
from ridsafe.tools.planner_loop.fleets import KinematicFleet
from ridsafe.tools.planner_loop.layout import HarnessConfig, make_layout


@pytest.mark.parametrize("seed", [0, 3, 11])
def test_the_layout_keeps_its_constraints(seed: int) -> None:
    cfg = HarnessConfig()
    layout = make_layout(cfg, seed)
    n = cfg.n_aircraft
    assert layout.start_ned_m.shape == layout.goal_ned_m.shape == (n, 3)
    trips = np.linalg.norm(layout.goal_ned_m[:, :2] - layout.start_ned_m[:, :2], axis=1)
    assert np.all((trips >= cfg.goal_min_m) & (trips <= cfg.goal_max_m))
    goals = layout.goal_ned_m[:, :2]
    gaps = np.linalg.norm(goals[:, None] - goals[None, :], axis=-1) + np.eye(n) * 1e9
    assert gaps.min() >= cfg.goal_spacing_m
    assert np.all(np.abs(goals) <= 0.9 * cfg.area_half_m)
    assert set(-layout.start_ned_m[:, 2]) <= set(cfg.cruise_alts_m)
    np.testing.assert_array_equal(layout.start_ned_m[:, 2], layout.goal_ned_m[:, 2])
    pads = np.linalg.norm(layout.start_ned_m[:, :2] - layout.spoofer_start_ned_m[:2], axis=1)
    assert pads.min() >= cfg.spoofer_clearance_m
    speed = float(np.linalg.norm(layout.spoofer_v_ned_m_s))
    assert speed == pytest.approx(cfg.spoofer_speed_m_s)
    assert np.all(np.linalg.eigvalsh(layout.region_cov_ned_m2) > 0.0)


def test_the_same_seed_gives_the_same_layout_and_another_seed_another() -> None:
    a, b, c = (
        make_layout(HarnessConfig(), 5),
        make_layout(HarnessConfig(), 5),
        make_layout(HarnessConfig(), 6),
    )
    np.testing.assert_array_equal(a.goal_ned_m, b.goal_ned_m)
    np.testing.assert_array_equal(a.spoofer_start_ned_m, b.spoofer_start_ned_m)
    assert not np.array_equal(a.goal_ned_m, c.goal_ned_m)


def test_kinematic_aircraft_reach_a_far_target_within_the_speed_limits() -> None:
    ctrl = ControllerParams()
    fleet = KinematicFleet(np.array([[0.0, 0.0, -50.0], [0.0, 0.0, -50.0]]), ctrl)
    fleet.set_target(0, np.array([300.0, 0.0, -50.0]), np.zeros(3))
    fleet.set_target(1, np.array([0.0, 0.0, -80.0]), np.zeros(3))  # climb 30 m
    top_xy = top_climb = 0.0
    for _ in range(round(90.0 / 0.05)):
        fleet.step(0.05)
        top_xy = max(top_xy, float(math.hypot(*fleet.v[0, :2])))
        top_climb = max(top_climb, float(-fleet.v[1, 2]))
    assert top_xy <= ctrl.max_speed_m_s + 1e-9 and top_xy > 0.9 * ctrl.max_speed_m_s
    assert top_climb <= ctrl.max_climb_m_s + 1e-9
    np.testing.assert_allclose(fleet.p, [[300.0, 0.0, -50.0], [0.0, 0.0, -80.0]], atol=0.5)
