"""The compiled rollout kernel against a plain numpy re-derivation from :mod:`value` and
:mod:`actions` (a differential test), and the scene's hazard projection and gating."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from ridsafe.companion.actions import ActionSet, build_action_set, heading_to_rad, rollout
from ridsafe.companion.planner_api import Neighbour, Region
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.planner_eval import (
    KernelParams,
    RolloutScores,
    _eigen,
    build_scene,
    score_actions,
)
from ridsafe.companion.value import (
    benign_reward,
    predicted_region,
    region_distance_m,
    region_intrusion_m,
    source_value,
)

FloatArray = NDArray[np.float64]
CHI2_95 = 7.814727903251178


def _t3(x: FloatArray) -> tuple[float, float, float]:
    return (float(x[0]), float(x[1]), float(x[2]))


def _region(center: tuple[float, float, float], t_s: float = 0.0) -> Region:
    cov = ((500.0, 100.0, 0.0), (100.0, 300.0, 0.0), (0.0, 0.0, 1600.0))
    return Region("SPOOF", center, cov, CHI2_95, (-6.0, 2.0, 0.0), t_s, t_s + 1.0)


def _random_case(
    seed: int,
) -> tuple[float, FloatArray, FloatArray, FloatArray, tuple[Neighbour, ...], tuple[Region, ...]]:
    rng = np.random.default_rng(seed)
    now = 20.0
    p0 = np.array([0.0, 0.0, -60.0])
    v0 = rng.uniform(-5.0, 5.0, 3) * [1, 1, 0.2]
    goal = np.array([*rng.uniform(-600.0, 600.0, 2), -60.0])
    neighbours = tuple(
        Neighbour(
            f"N{j}",
            _t3(rng.uniform(-150.0, 150.0, 3) * [1, 1, 0.1] + [0, 0, -60]),
            _t3(rng.uniform(-8.0, 8.0, 3) * [1, 1, 0.1]),
            now - rng.uniform(0.0, 1.0),
            False,
        )
        for j in range(8)
    )
    center = (float(rng.uniform(60.0, 140.0)), float(rng.uniform(-80.0, 80.0)), -60.0)
    return now, p0, v0, goal, neighbours, (_region(center, now - 0.3),)


def _reference(
    now: float,
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    actions: ActionSet,
    neighbours: tuple[Neighbour, ...],
    regions: tuple[Region, ...],
    cfg: PlannerConfig,
) -> RolloutScores:
    """The module docstring of planner_eval, term by term, with numpy and value.py."""
    tau = np.asarray(cfg.sample_times_s)
    dt = cfg.horizon_s / cfg.n_samples
    path, _ = rollout(p0, v0, actions.velocity_ned_m_s, tau, cfg.accel_m_s2)  # (A, K, 3)
    d_goal = np.linalg.norm(path - goal, axis=-1)
    goal_term = source_value(cfg.goal_reward, cfg.goal_decay, cfg.goal_gate_m, d_goal).mean(1)
    goal_term += _extension_reference(now, path[:, -1], goal, regions, cfg)
    hazard = np.zeros(path.shape[:2])
    min_sep = np.full(len(actions), np.inf)
    for n in neighbours:
        q = np.asarray(n.p_ned_m) + np.asarray(n.v_ned_m_s) * (now - n.t_s + tau)[:, None]
        e = path - q
        d = np.linalg.norm(e, axis=-1)  # (A, K): the separation
        e[..., 2] *= cfg.benign_vertical_weight  # the benign term's distance
        d_w = np.linalg.norm(e, axis=-1)
        inside = d_w < cfg.d_safe_m
        conflict_s = dt * (np.cumsum(inside, axis=1) - inside)
        reward = benign_reward(cfg.benign_reward_base, cfg.benign_reward_per_s, conflict_s)
        hazard = np.minimum(hazard, source_value(reward, cfg.benign_decay, cfg.d_safe_m, d_w))
        min_sep = np.minimum(min_sep, d.min(axis=1))
    intrusion = np.zeros(len(actions))
    for r in regions:
        age = now - r.t_s
        threshold = _threshold(now, p0, r, cfg)
        for k, t in enumerate(tau):
            c, cov = predicted_region(r.center_ned_m, r.v_ned_m_s, r.cov_ned_m2, 1.0, age + t)
            intrusion += region_intrusion_m(path[:, k], c, cov, r.chi2_threshold, threshold)
            d = region_distance_m(path[:, k], c, cov, r.chi2_threshold)
            term = source_value(cfg.region_reward, cfg.region_decay, cfg.region_gate_m, d)
            hazard[:, k] = np.minimum(hazard[:, k], term)
    h = hazard.min(axis=1) + cfg.hazard_mean_weight * hazard.mean(axis=1)
    floor_ok = (path[..., 2] <= -cfg.min_altitude_m) | (path[..., 2] <= p0[2] + 1.0)
    ceiling_ok = (path[..., 2] >= -cfg.max_altitude_m) | (path[..., 2] >= p0[2] - 1.0)
    envelope_ok = np.all(floor_ok & ceiling_ok, axis=1)
    return RolloutScores(goal_term, h, intrusion, envelope_ok, min_sep, len(goal_term))


def _threshold(now: float, p0: FloatArray, r: Region, cfg: PlannerConfig) -> float:
    c0, cov0 = predicted_region(r.center_ned_m, r.v_ned_m_s, r.cov_ned_m2, 1.0, now - r.t_s)
    d_now = float(region_distance_m(p0, c0, cov0, r.chi2_threshold))
    return min(max(d_now, 1.0), cfg.region_margin_m)


def _intrusion(
    now: float,
    p0: FloatArray,
    points: FloatArray,
    t: float,
    regions: tuple[Region, ...],
    cfg: PlannerConfig,
) -> FloatArray:
    total = np.zeros(points.shape[0])
    for r in regions:
        c, cov = predicted_region(r.center_ned_m, r.v_ned_m_s, r.cov_ned_m2, 1.0, now - r.t_s + t)
        total += region_intrusion_m(points, c, cov, r.chi2_threshold, _threshold(now, p0, r, cfg))
    return total


def _extension_reference(
    now: float, end: FloatArray, goal: FloatArray, regions: tuple[Region, ...], cfg: PlannerConfig
) -> FloatArray:
    """The mean goal term each rollout's extension (straight at the goal at max speed) loses by
    halting before a region, against flying on unhindered: ``end : (A, 3)``."""
    p0 = np.array([0.0, 0.0, -60.0])
    length = np.linalg.norm(goal - end, axis=1)
    u = (goal - end) / length[:, None]
    cap, done, lost = length.copy(), np.zeros(len(end)), np.zeros(len(end))
    for t in cfg.extension_times_s:
        free = np.minimum(cfg.max_speed_m_s * (t - cfg.horizon_s), length)
        step = np.minimum(free, cap)
        moving = step > done
        blocked = moving & (_intrusion(now, p0, end + u * step[:, None], t, regions, cfg) > 0.0)
        cap = np.where(blocked, done, cap)
        done = np.where(moving & ~blocked, step, done)
        value = [
            source_value(cfg.goal_reward, cfg.goal_decay, cfg.goal_gate_m, length - x)
            for x in (done, free)
        ]
        lost += value[0] - value[1]
    return lost / cfg.extension_samples


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize(("mean_weight", "vertical_weight"), [(0.0, 1.0), (0.7, 1.0), (0.0, 2.5)])
def test_kernel_matches_the_numpy_reference(
    seed: int, mean_weight: float, vertical_weight: float
) -> None:
    cfg = PlannerConfig(hazard_mean_weight=mean_weight, benign_vertical_weight=vertical_weight)
    now, p0, v0, goal, neighbours, regions = _random_case(seed)
    actions = build_action_set(cfg, heading_to_rad(p0, goal))
    scene = build_scene(now, p0, neighbours, regions, cfg)
    assert len(scene.nb_ids) >= 4 and len(scene.rg_ids) == 1
    got = score_actions(p0, v0, goal, actions, scene, KernelParams.from_config(cfg))
    # the reference takes every neighbour: the scene's gating must not change any score
    want = _reference(now, p0, v0, goal, actions, neighbours, regions, cfg)
    np.testing.assert_allclose(got.goal, want.goal, rtol=1e-10)
    np.testing.assert_allclose(got.hazard, want.hazard, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got.intrusion_m, want.intrusion_m, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        np.minimum(got.min_separation_m, cfg.d_safe_m),
        np.minimum(want.min_separation_m, cfg.d_safe_m),
        rtol=1e-10,
    )
    np.testing.assert_array_equal(got.envelope_ok, want.envelope_ok)
    assert np.count_nonzero(want.hazard < 0) > 100  # the case exercises the hazards
    assert np.count_nonzero(want.intrusion_m > 0) > 50
    # and the extension is blocked for some actions and not for others
    ends, _ = rollout(p0, v0, actions.velocity_ned_m_s, [cfg.horizon_s], cfg.accel_m_s2)
    lost = _extension_reference(now, ends[:, 0], goal, regions, cfg)
    assert np.any(lost < 0.0) and np.any(lost == 0.0)


def test_altitude_band_rejects_descents_below_the_floor() -> None:
    cfg = PlannerConfig()
    p0, v0 = np.array([0.0, 0.0, -12.0]), np.zeros(3)  # 12 m up, floor 10 m
    actions = build_action_set(cfg, 0.0)
    scene = build_scene(0.0, p0, (), (), cfg)
    scores = score_actions(
        p0, v0, np.array([500.0, 0, -12.0]), actions, scene, KernelParams.from_config(cfg)
    )
    descending = actions.velocity_ned_m_s[:, 2] * cfg.horizon_s > 2.0 + 1.0
    assert not np.any(scores.envelope_ok[descending])
    assert np.all(scores.envelope_ok[actions.velocity_ned_m_s[:, 2] <= 0.0])


def test_scene_projects_neighbours_along_their_rid_velocity() -> None:
    cfg = PlannerConfig()
    nb = Neighbour("A", (100.0, 0.0, -60.0), (0.0, 5.0, 0.0), 9.0, False)  # heard 1 s ago
    scene = build_scene(10.0, np.array([0.0, 0.0, -60.0]), (nb,), (), cfg)
    tau = np.asarray(cfg.sample_times_s)
    np.testing.assert_allclose(scene.nb_pos_m[0, :, 1], 5.0 * (1.0 + tau))
    np.testing.assert_allclose(scene.nb_pos_m[0, :, 0], 100.0)


def test_scene_drops_what_cannot_matter() -> None:
    cfg = PlannerConfig()
    p0 = np.zeros(3)
    near = Neighbour("near", (150.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, False)
    # 500 m away, moving away: never within d_safe + 8 m/s * tau of p0
    far = Neighbour("far", (500.0, 0.0, 0.0), (5.0, 0.0, 0.0), 0.0, False)
    expired = Region(
        "old", (100.0, 0.0, 0.0), _region((0, 0, 0)).cov_ned_m2, CHI2_95, (0, 0, 0), -5, -1
    )
    distant = _region((2000.0, 0.0, 0.0))
    scene = build_scene(0.0, p0, (near, far), (expired, distant, _region((200.0, 0.0, 0.0))), cfg)
    assert scene.nb_ids == ("near",)
    assert scene.rg_ids == ("SPOOF",)
    assert scene.rg_center_m.shape == (1, cfg.n_samples + cfg.extension_samples, 3)


@pytest.mark.parametrize("field", range(7))
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_scene_leaves_out_a_neighbour_with_a_non_finite_number(field: int, bad: float) -> None:
    """Position, velocity or receive time: whatever is not finite, the neighbour is not in
    the scene, and those beside it are."""
    values = [50.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # 50 m away, still, heard now
    values[field] = bad
    p, v, t_s = (values[0], values[1], values[2]), (values[3], values[4], values[5]), values[6]
    broken = Neighbour("broken", p, v, t_s, False)
    fine = Neighbour("fine", (60.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, False)
    scene = build_scene(0.0, np.zeros(3), (broken, fine), (), PlannerConfig())
    assert scene.nb_ids == ("fine",)
    assert np.all(np.isfinite(scene.nb_pos_m))


def test_shield_threshold_is_the_current_distance_inside_the_margin() -> None:
    cfg = PlannerConfig(region_margin_m=50.0, region_velocity_std_m_s=0.0)
    sigma = math.sqrt(CHI2_95) * 20.0
    cov = ((400.0, 0.0, 0.0), (0.0, 400.0, 0.0), (0.0, 0.0, 400.0))
    for gap, want in ((30.0, 30.0), (80.0, 50.0), (-10.0, 1.0)):  # inside the ellipsoid: 1 m
        region = Region("S", (sigma + gap, 0.0, 0.0), cov, CHI2_95, (0.0, 0.0, 0.0), 0.0, 5.0)
        scene = build_scene(0.0, np.zeros(3), (), (region,), cfg)
        assert scene.rg_threshold_m[0] == pytest.approx(want)


def test_degenerate_covariance_is_floored() -> None:
    cov = ((0.0, 0.0, 0.0), (0.0, -5.0, 0.0), (0.0, 0.0, 0.0))
    region = Region("S", (30.0, 0.0, 0.0), cov, CHI2_95, (0.0, 0.0, 0.0), 0.0, 5.0)
    scene = build_scene(0.0, np.zeros(3), (), (region,), PlannerConfig())
    assert np.all(np.isfinite(scene.rg_pinv_1_m2)) and np.all(scene.rg_sigma_min_m >= 1.0)


def test_cached_region_eigen_equals_the_stacked_decomposition() -> None:
    """The per-region cache (planner_eval._eigen) gives the bits eigh gives on the stack."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        a = rng.normal(size=(3, 3, 3)) * rng.uniform(1.0, 100.0)
        cov = a @ np.swapaxes(a, -1, -2)
        lam, vec = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, -1, -2)))
        cached = [_eigen(np.array(c).tobytes()) for c in cov]
        np.testing.assert_array_equal(np.maximum(lam, 1.0), [e[0] for e in cached])
        np.testing.assert_array_equal(vec, [e[1] for e in cached])
