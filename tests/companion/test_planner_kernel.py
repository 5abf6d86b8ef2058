"""The bounded scoring (``planner_kernel.score_bounded``) against scoring every action: on
random scenes of every kind (far from and at the goal, traffic now and ahead, unsafe regions,
near the altitude floor, other reward settings) ``choose_action`` picks the same action with
the same status and value, and the hover's entries the planner reads are the same."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.companion.actions import build_action_set, heading_to_rad
from ridsafe.companion.planner import choose_action
from ridsafe.companion.planner_api import Neighbour, Region
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.planner_eval import KernelParams, RolloutScores, build_scene, score_actions
from ridsafe.companion.planner_kernel import TIGHTEN_AFTER, _goal_bounds
from ridsafe.companion.ramp_kernel import rollout_into

FloatArray = NDArray[np.float64]
CHI2_95 = 7.814727903251178
CONFIGS = {
    "default": PlannerConfig(),
    "mean hazard, weighted vertical": PlannerConfig(
        hazard_mean_weight=0.5, goal_vertical_weight=2.0
    ),
    "short goal gate, no bias": PlannerConfig(goal_gate_m=300.0, right_turn_bias=0.0),
    "strong bias": PlannerConfig(right_turn_bias=5000.0, goal_decay=0.99),
}


def _t3(x: FloatArray) -> tuple[float, float, float]:
    return (float(x[0]), float(x[1]), float(x[2]))


def _scene_case(
    rng: np.random.Generator,
) -> tuple[float, FloatArray, FloatArray, FloatArray, tuple[Neighbour, ...], tuple[Region, ...]]:
    """A random state: goal 0-800 m away (often within the approach radius), 0-12 neighbours
    within 0-400 m (some within d_safe now), 0-2 regions, at 12-110 m altitude."""
    now = 30.0
    p0 = np.array([0.0, 0.0, -rng.uniform(12.0, 110.0)])
    v0 = rng.uniform(-8.0, 8.0, 3) * [1.0, 1.0, 0.25]
    goal_range = rng.choice([5.0, 40.0, 150.0, 800.0])
    goal = p0 + rng.uniform(-goal_range, goal_range, 3) * [1.0, 1.0, 0.05]
    neighbours = tuple(
        Neighbour(
            f"N{j}",
            _t3(p0 + rng.uniform(-1.0, 1.0, 3) * [rng.uniform(30.0, 400.0)] * 2 + [0.0]),
            _t3(rng.uniform(-8.0, 8.0, 3) * [1.0, 1.0, 0.1]),
            now - rng.uniform(0.0, 2.0),
            False,
        )
        for j in range(int(rng.integers(0, 13)))
    )
    regions = tuple(
        Region(
            f"S{r}",
            _t3(p0 + rng.uniform(-250.0, 250.0, 3) * [1.0, 1.0, 0.1]),
            ((400.0, 80.0, 0.0), (80.0, 300.0, 0.0), (0.0, 0.0, 900.0)),
            CHI2_95,
            _t3(rng.uniform(-7.0, 7.0, 3) * [1.0, 1.0, 0.0]),
            now - 0.5,
            now + 1.0,
        )
        for r in range(int(rng.integers(0, 3)))
    )
    return now, p0, v0, goal, neighbours, regions


def _both(
    cfg: PlannerConfig, seed: int
) -> tuple[RolloutScores, RolloutScores, int, int, tuple[int, object, float]]:
    now, p0, v0, goal, neighbours, regions = _scene_case(np.random.default_rng(seed))
    actions = build_action_set(cfg, heading_to_rad(p0, goal))
    scene = build_scene(now, p0, neighbours, regions, cfg)
    kp = KernelParams.from_config(cfg)
    every = score_actions(p0, v0, goal, actions, scene, kp)
    bounded = score_actions(p0, v0, goal, actions, scene, kp, cfg.right_turn_bias)
    want = choose_action(every, actions, cfg)
    assert choose_action(bounded, actions, cfg) == want
    return every, bounded, len(actions) - 1, want[0], want


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_bounded_scoring_chooses_what_scoring_every_action_chooses(name: str) -> None:
    cfg = CONFIGS[name]
    pruned = 0
    for seed in range(150):
        every, bounded, hover, index, _ = _both(cfg, seed)
        np.testing.assert_array_equal(bounded.envelope_ok, every.envelope_ok)
        for a in (hover, index):  # what the planner reads besides the choice
            assert bounded.goal[a] == every.goal[a]
            assert bounded.hazard[a] == every.hazard[a]
            assert bounded.intrusion_m[a] == every.intrusion_m[a]
            assert bounded.min_separation_m[a] == every.min_separation_m[a]
        scored = np.isfinite(bounded.hazard)
        assert np.count_nonzero(scored) == bounded.n_scored
        np.testing.assert_array_equal(bounded.hazard[scored], every.hazard[scored])
        pruned += bounded.n_scored < len(every.goal)
    assert pruned > 100  # and the bound does leave actions out


def test_without_a_safe_action_every_action_is_scored() -> None:
    cfg = PlannerConfig()
    p0, v0 = np.array([0.0, 0.0, -60.0]), np.zeros(3)
    inside = Region("S", _t3(p0), ((900.0, 0, 0), (0, 900.0, 0), (0, 0, 900.0)), CHI2_95,
                    (0.0, 0.0, 0.0), 0.0, 5.0)  # fmt: skip
    goal = np.array([500.0, 0.0, -60.0])
    actions = build_action_set(cfg, heading_to_rad(p0, goal))
    scene = build_scene(0.0, p0, (), (inside,), cfg)
    kp = KernelParams.from_config(cfg)
    bounded = score_actions(p0, v0, goal, actions, scene, kp, cfg.right_turn_bias)
    every = score_actions(p0, v0, goal, actions, scene, kp)
    assert bounded.n_scored == len(actions)
    assert choose_action(bounded, actions, cfg) == choose_action(every, actions, cfg)
    np.testing.assert_array_equal(bounded.intrusion_m, every.intrusion_m)


def test_a_clear_sky_scores_few_actions() -> None:
    cfg = PlannerConfig()
    p0, v0 = np.array([0.0, 0.0, -60.0]), np.array([4.0, 0.0, 0.0])
    goal = np.array([400.0, 300.0, -60.0])
    actions = build_action_set(cfg, heading_to_rad(p0, goal))
    scene = build_scene(0.0, p0, (), (), cfg)
    kp = KernelParams.from_config(cfg)
    bounded = score_actions(p0, v0, goal, actions, scene, kp, cfg.right_turn_bias)
    assert bounded.n_scored < len(actions) // 10
    every = score_actions(p0, v0, goal, actions, scene, kp)
    assert choose_action(bounded, actions, cfg) == choose_action(every, actions, cfg)


def test_hazards_met_later_tighten_the_bound() -> None:
    """Random case 36 (default config): the first sample's hazard leaves every action's bound
    above the best one found (all 1,095 were scored with it alone); the hazard of the middle
    and last samples (``planner_kernel.TIGHTEN_AFTER``) leaves about a fifth, and the choice
    is the one scoring every action makes (``_both`` asserts it)."""
    _, bounded, _, _, _ = _both(PlannerConfig(), 36)
    assert TIGHTEN_AFTER < bounded.n_scored < 300


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_every_goal_bound_is_above_its_goal_term(name: str) -> None:
    """The vectorised first pass (``planner_kernel._goal_bounds``, every action at once): its
    U_a is at least the G_a that scoring finds, E_a is scoring's, and each rollout's first
    sample is the rollout's own, bit for bit."""
    cfg = CONFIGS[name]
    kp = KernelParams.from_config(cfg)
    tight = 0
    for seed in range(60):
        now, p0, v0, goal, neighbours, regions = _scene_case(np.random.default_rng(seed))
        actions = build_action_set(cfg, heading_to_rad(p0, goal))
        scene = build_scene(now, p0, neighbours, regions, cfg)
        every = score_actions(p0, v0, goal, actions, scene, kp)
        va = np.ascontiguousarray(actions.velocity_ned_m_s)
        n = len(actions)
        bound, ok, first = np.empty(n), np.empty(n, dtype=np.bool_), np.empty((n, 3))
        _goal_bounds(p0, v0, goal, va, scene.tau_s, kp, bound, ok, first)
        assert np.all(bound >= every.goal)
        np.testing.assert_array_equal(ok, every.envelope_ok)
        path = np.empty((scene.tau_s.shape[0], 3))
        for a in range(0, n, 7):
            rollout_into(p0, v0, va[a], scene.tau_s, kp.accel, path)
            np.testing.assert_array_equal(first[a], path[0])
        tight += int(np.count_nonzero(bound - every.goal < 1e-3 * np.abs(every.goal) + 1e-12))
    assert tight > 0  # some bounds are (nearly) the goal term itself: not +inf everywhere
