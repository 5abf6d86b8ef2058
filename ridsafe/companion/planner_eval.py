"""Scoring every action's rollout at once: the planner's compiled hot loop.

For action a with rollout samples p_k = p_a(tau_k), k = 1..K (``actions`` eq. 2), and the
value terms of :mod:`ridsafe.companion.value` (eqs. 1-5)::

    G_a  = (1/K) sum_k V_goal(p_k) + X_a                    mean goal term along the rollout
    H_a  = min_k h_k + w (1/K) sum_k h_k                     worst hazard (w = 0 by default)
    h_k  = min( min_j V_benign(d_kj, t_kj), min_r V_region(d_r(p_k, tau_k)) )     value eq. 2
    d_kj = |p_k - (q_j + w_j (age_j + tau_k))|               neighbour j moved along its RID
                                                              velocity w_j, not frozen
    t_kj = dt #{i < k : d_ij < d_safe}                        conflict time so far (value eq. 3)
    I_a  = sum_k sum_r max(0, m_r - d_r(p_k, tau_k))          shield intrusion (m), eqs. 4-5
    m_r  = min(max(d_r(p_0, 0), 1 m), margin)                 the shield's threshold
    E_a  : no sample below min(floor, own altitude - 1 m) nor above max(ceiling, altitude + 1 m)

Extension (ours): from the rollout's end p_K the aircraft is assumed to fly on straight at the
goal g at max speed for K2 more samples, f_i = p_K + min(v_max i dt_e, |g - p_K|) u, but to
halt before the first sample that would enter a region (e_i = last free f)::

    X_a  = (1/K2) sum_i V_goal(e_i) - V_goal(f_i)  <= 0      what the regions will still block

so a rollout that ends with the region between the aircraft and its goal (running alongside
a spoofer) loses against one that lets the region pass; without regions X_a = 0.

The planner maximises J_a = G_a + H_a + b sin(psi_a - psi_goal) over the actions with
I_a = 0 and E_a (see :mod:`ridsafe.companion.planner`). A rollout "enters" a region when it
comes closer than ``region_margin_m`` to its surface; an aircraft already inside that band
(the region came to it) may keep its distance but not close in (m_r = its current distance),
and one inside the ellipsoid itself has no safe action: the least intrusion is the quickest
way out. H_a is a worst case over time rather than a mean: a close pass at one sample must not
be averaged away by the others.

The kernel loops over actions x samples x (neighbours + regions) in compiled code, with no
(A, K, N) temporaries. Two things keep the neighbour loop short. Per sample, only neighbours
that some rollout can come within d_safe of are visited (every rollout stays within
max(|v0|, |v_a|) tau_k of p0). And since every benign reward is negative, the worst benign
term is one exp per sample, not one per neighbour::

    min_j R_j scale gamma^d_kj = -scale exp( max_j ( ln|R(t_kj)| + d_kj ln gamma ) )

with ln|R(t)| tabulated for t = 0, dt, ..., K dt. About 2 ms for 1,095 actions x 20 samples
x 16 neighbours + 1 region when every neighbour stays within d_safe, well under 1 ms in a
flight's typical scene (bench/bench_planner.py).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple, TypeVar, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ridsafe.companion.actions import ActionSet
from ridsafe.companion.planner_api import Neighbour, Region
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.value import source_coefficient

__all__ = ["KernelParams", "RolloutScores", "Scene", "build_scene", "score_actions"]

FloatArray = NDArray[np.float64]
_F = TypeVar("_F", bound=Callable[..., Any])

# Covariance eigenvalues are floored here (m^2): a degenerate region still has a volume.
MIN_EIGENVALUE_M2 = 1.0
# The shield's threshold never drops below this (m): inside the ellipsoid nothing is safe.
MIN_SHIELD_M = 1.0
# Rollouts may descend below the floor (climb above the ceiling) by this much: a hover from a
# descending state sinks v^2 / (2 a) < 0.5 m before it stops.
ENVELOPE_SLACK_M = 1.0


def _jit(fn: _F) -> _F:
    """``numba.njit(cache=True)`` with the signature kept for mypy."""
    return cast(_F, njit(cache=True)(fn))


def _inline(fn: _F) -> _F:
    """``_jit`` for the kernel's small helpers, inlined into their caller at numba's IR level:
    a call per sample otherwise costs as much as the arithmetic it does."""
    return cast(_F, njit(cache=True, inline="always")(fn))


class KernelParams(NamedTuple):
    """The scalars of the kernel (config turned into coefficients and log-decays)."""

    accel: float
    goal_coef: float
    goal_ln_decay: float
    goal_gate: float
    goal_vertical_weight: float
    benign_base: float
    benign_rate: float
    benign_scale: float  # 1 / (1 - gamma^2)
    benign_ln_decay: float
    d_safe: float
    sample_dt: float
    region_coef: float
    region_ln_decay: float
    region_gate: float
    hazard_mean_weight: float
    max_speed: float
    extension_dt: float
    extension_n: int
    floor_down: float
    ceiling_down: float

    @classmethod
    def from_config(cls, cfg: PlannerConfig) -> KernelParams:
        return cls(
            cfg.accel_m_s2,
            source_coefficient(cfg.goal_reward, cfg.goal_decay),
            math.log(cfg.goal_decay),
            cfg.goal_gate_m,
            cfg.goal_vertical_weight,
            cfg.benign_reward_base,
            cfg.benign_reward_per_s,
            1.0 / (1.0 - cfg.benign_decay**2),
            math.log(cfg.benign_decay),
            cfg.d_safe_m,
            cfg.horizon_s / cfg.n_samples,
            source_coefficient(cfg.region_reward, cfg.region_decay),
            math.log(cfg.region_decay),
            cfg.region_gate_m,
            cfg.hazard_mean_weight,
            cfg.max_speed_m_s,
            cfg.extension_s / max(cfg.extension_samples, 1),
            cfg.extension_samples,
            -cfg.min_altitude_m,
            -cfg.max_altitude_m,
        )


@dataclass(frozen=True)
class Scene:
    """Hazards over the rollout times tau : (K,) (N neighbours, R regions kept for this decision).

    ``nb_pos_m : (N, K, 3)`` neighbour positions at each tau; the regions over the rollout and
    then the extension's times (K + K2): ``rg_center_m : (R, K + K2, 3)``,
    ``rg_pinv_1_m2 : (R, K + K2, 3, 3)`` = P(tau)^-1, ``rg_sigma_min_m : (R, K + K2)`` =
    sqrt(lambda_min(P(tau))), ``rg_sqrt_chi2 : (R,)``, ``rg_threshold_m : (R,)`` the shield's
    threshold m_r.
    """

    tau_s: FloatArray
    nb_ids: tuple[str, ...]
    nb_pos_m: FloatArray
    rg_ids: tuple[str, ...]
    rg_center_m: FloatArray
    rg_pinv_1_m2: FloatArray
    rg_sigma_min_m: FloatArray
    rg_sqrt_chi2: FloatArray
    rg_threshold_m: FloatArray


@dataclass(frozen=True)
class RolloutScores:
    """Per action (A,): G_a, H_a, I_a, E_a of the module docstring and the closest predicted
    approach to a neighbour (m): exact below d_safe; at or above it, only a lower bound on
    how far every neighbour stays (inf when none can come within d_safe)."""

    goal: FloatArray
    hazard: FloatArray
    intrusion_m: FloatArray
    envelope_ok: NDArray[np.bool_]
    min_separation_m: FloatArray


def build_scene(
    now_s: float,
    p0_m: FloatArray,
    neighbours: tuple[Neighbour, ...],
    regions: tuple[Region, ...],
    cfg: PlannerConfig,
) -> Scene:
    """Project the hazards over the rollout times; drop those that cannot matter.

    A neighbour is kept when, at some tau, it is within d_safe + v_max tau of p0 (the rollout
    cannot be farther from p0 than v_max tau); a region when its (inflated) ellipsoid comes
    within max(gate, margin) + v_max tau. Callers filter by policy (flagged, stale) first.
    """
    tau, tau_all = _rollout_times(cfg)  # (K,); (1 + K + K2,): now, rollout, extension
    reach = cfg.max_speed_m_s * tau  # (K,)
    nb_ids, nb_pos = _neighbour_positions(now_s, neighbours, tau)
    if nb_pos.shape[0]:
        dist = np.linalg.norm(nb_pos - p0_m, axis=-1)  # (N, K)
        keep = np.any(dist < cfg.d_safe_m + reach, axis=1)
        nb_ids = tuple(i for i, k in zip(nb_ids, keep, strict=True) if k)
        nb_pos = nb_pos[keep]
    live = tuple(r for r in regions if r.valid_until_s >= now_s)
    if not live:  # the common case: none of the region arithmetic below
        no_regions = _region_arrays(now_s, (), tau_all[1:], 0.0)
        return Scene(tau, nb_ids, nb_pos, (), *no_regions, np.zeros(0), np.zeros(0))
    center, pinv, sigma = _region_arrays(now_s, live, tau_all, cfg.region_velocity_std_m_s)
    sqrt_chi2 = np.sqrt(np.array([r.chi2_threshold for r in live], dtype=np.float64))
    delta = p0_m - center  # (R, 1 + K + K2, 3)
    m = np.einsum("rki,rkij,rkj->rk", delta, pinv, delta)
    d = sigma * np.maximum(0.0, np.sqrt(np.maximum(m, 0.0)) - sqrt_chi2[:, None])
    threshold = np.minimum(np.maximum(d[:, 0], MIN_SHIELD_M), cfg.region_margin_m)
    near = max(cfg.region_gate_m, cfg.region_margin_m) + cfg.max_speed_m_s * tau_all[1:]
    keep_r = np.any(d[:, 1:] < near, axis=1)
    return Scene(
        tau,
        nb_ids,
        nb_pos,
        tuple(r.uas_id for r, k in zip(live, keep_r, strict=True) if k),
        center[keep_r, 1:],
        pinv[keep_r, 1:],
        sigma[keep_r, 1:],
        sqrt_chi2[keep_r],
        threshold[keep_r],
    )


@functools.lru_cache(maxsize=16)
def _rollout_times(cfg: PlannerConfig) -> tuple[FloatArray, FloatArray]:
    """The rollout's sample times tau : (K,) and (0, tau, extension times) : (1 + K + K2,)."""
    tau = np.asarray(cfg.sample_times_s, dtype=np.float64)
    tau_all = np.concatenate([[0.0], tau, cfg.extension_times_s])
    tau.setflags(write=False)
    tau_all.setflags(write=False)
    return tau, tau_all


def _neighbour_positions(
    now_s: float, neighbours: tuple[Neighbour, ...], tau: FloatArray
) -> tuple[tuple[str, ...], FloatArray]:
    """q_j + w_j (now - t_j + tau_k) for every neighbour: ``(N, K, 3)``."""
    if not neighbours:
        return (), np.zeros((0, tau.shape[0], 3))
    q = np.array([n.p_ned_m for n in neighbours], dtype=np.float64)
    w = np.array([n.v_ned_m_s for n in neighbours], dtype=np.float64)
    age = now_s - np.array([n.t_s for n in neighbours], dtype=np.float64)
    horizon = age[:, None] + tau[None, :]  # (N, K)
    pos: FloatArray = q[:, None, :] + w[:, None, :] * horizon[..., None]
    return tuple(n.uas_id for n in neighbours), pos


def _region_arrays(
    now_s: float, regions: tuple[Region, ...], tau: FloatArray, sigma_v: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Centres (R, K, 3), inverse covariances (R, K, 3, 3), sqrt(lambda_min) (R, K), value eq. 5.

    Eigenvalues below MIN_EIGENVALUE_M2 are raised to it (a malformed, indefinite covariance
    still yields a sane ellipsoid).
    """
    k = tau.shape[0]
    if not regions:
        return np.zeros((0, k, 3)), np.zeros((0, k, 3, 3)), np.zeros((0, k))
    c = np.array([r.center_ned_m for r in regions], dtype=np.float64)
    v = np.array([r.v_ned_m_s for r in regions], dtype=np.float64)
    cov = np.array([r.cov_ned_m2 for r in regions], dtype=np.float64)
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    lam, vec = np.linalg.eigh(cov)  # (R, 3), (R, 3, 3)
    lam = np.maximum(lam, MIN_EIGENVALUE_M2)
    horizon = (now_s - np.array([r.t_s for r in regions]))[:, None] + tau[None, :]  # (R, K)
    horizon = np.maximum(horizon, 0.0)
    center: FloatArray = c[:, None, :] + v[:, None, :] * horizon[..., None]
    lam_k = lam[:, None, :] + ((sigma_v * horizon) ** 2)[..., None]  # (R, K, 3)
    pinv: FloatArray = np.einsum("rij,rkj,rlj->rkil", vec, 1.0 / lam_k, vec)
    sigma_min: FloatArray = np.sqrt(lam_k.min(axis=-1))
    return center, pinv, sigma_min


def score_actions(
    p0_m: FloatArray,
    v0_m_s: FloatArray,
    goal_m: FloatArray,
    actions: ActionSet,
    scene: Scene,
    kp: KernelParams,
) -> RolloutScores:
    """Run the kernel over every action of ``actions`` (positions in the local NED frame)."""
    n = len(actions)
    out = np.empty((4, n))
    ok = np.empty(n, dtype=np.bool_)
    _score_kernel(
        np.ascontiguousarray(p0_m, dtype=np.float64),
        np.ascontiguousarray(v0_m_s, dtype=np.float64),
        np.ascontiguousarray(goal_m, dtype=np.float64),
        np.ascontiguousarray(actions.velocity_ned_m_s),
        scene.tau_s,
        np.ascontiguousarray(scene.nb_pos_m.transpose(1, 0, 2)),
        (
            np.ascontiguousarray(scene.rg_center_m),
            np.ascontiguousarray(scene.rg_pinv_1_m2),
            np.ascontiguousarray(scene.rg_sigma_min_m),
            np.ascontiguousarray(scene.rg_sqrt_chi2),
            np.ascontiguousarray(scene.rg_threshold_m),
        ),
        kp,
        out,
        ok,
    )
    return RolloutScores(out[0], out[1], out[2], ok, out[3])


@_inline
def _region_distance(
    x: float, y: float, z: float, c: FloatArray, pinv: FloatArray, sigma: float, sqrt_chi2: float
) -> float:
    """Value eq. 4 for one point against one (already predicted) region."""
    dx, dy, dz = x - c[0], y - c[1], z - c[2]
    m = (
        pinv[0, 0] * dx * dx
        + pinv[1, 1] * dy * dy
        + pinv[2, 2] * dz * dz
        + 2.0 * (pinv[0, 1] * dx * dy + pinv[0, 2] * dx * dz + pinv[1, 2] * dy * dz)
    )
    return sigma * max(0.0, math.sqrt(max(m, 0.0)) - sqrt_chi2)


@_jit
def _score_kernel(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    regions: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    kp: KernelParams,
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> None:
    """Fill ``out[0..3, a]`` = G_a, H_a, I_a, min separation and ``ok[a]`` = E_a.

    ``nb_by_time : (K, N, 3)`` are the neighbours' positions, sample-major; ``regions`` =
    (centre, P^-1, sqrt(lambda_min), sqrt(chi2), shield threshold) of the Scene.
    """
    n_k = tau.shape[0]
    path = np.empty((n_k, 3))
    near, n_near = _near_neighbours(p0, v0, va, tau, nb_by_time, kp.d_safe)
    ln_reward = _benign_ln_reward(n_k, kp)
    conflicts = np.zeros(nb_by_time.shape[1], dtype=np.int64)
    d_safe2 = kp.d_safe * kp.d_safe
    for a in range(va.shape[0]):
        _rollout_into(p0, v0, va[a], tau, kp.accel, path)
        conflicts[:] = 0
        goal_sum, worst, hazard_sum, intrusion, min_d2 = 0.0, 0.0, 0.0, 0.0, np.inf
        envelope_ok = True
        for k in range(n_k):
            x, y, z = path[k, 0], path[k, 1], path[k, 2]
            goal_sum += _goal_term(x - goal[0], y - goal[1], z - goal[2], kp)
            envelope_ok = envelope_ok and _in_altitude_band(z, p0[2], kp)
            best, d2 = -np.inf, np.inf
            for i in range(n_near[k]):
                ex, ey, ez = x - near[k, i, 1], y - near[k, i, 2], z - near[k, i, 3]
                e2 = ex * ex + ey * ey + ez * ez
                d2 = min(d2, e2)
                if e2 < d_safe2:
                    j = int(near[k, i, 0])
                    best = max(best, ln_reward[conflicts[j]] + math.sqrt(e2) * kp.benign_ln_decay)
                    conflicts[j] += 1
            h = 0.0 if best == -np.inf else -kp.benign_scale * math.exp(best)
            h_region, intruded = _region_hazard(x, y, z, k, regions, kp)
            h = min(h, h_region)
            worst, hazard_sum = min(worst, h), hazard_sum + h
            min_d2, intrusion = min(min_d2, d2), intrusion + intruded
        out[0, a] = goal_sum / n_k + _extension_loss(path[n_k - 1], goal, n_k, regions, kp)
        out[1, a] = worst + kp.hazard_mean_weight * hazard_sum / n_k
        out[2, a] = intrusion
        out[3, a] = math.sqrt(min_d2)
        ok[a] = envelope_ok


@_jit
def _near_neighbours(
    p0: FloatArray,
    v0: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    d_safe: float,
) -> tuple[FloatArray, NDArray[np.int64]]:
    """The neighbours some rollout may come within d_safe of, per sample: ``near[k, :n[k]]``
    rows are (index j, north, east, down).

    Along a ramp the speed never exceeds max(|v0|, |v_a|) (``actions`` eq. 2), so every
    rollout is within ``reach_k`` = that speed x tau_k of p0 at sample k; a neighbour at
    least d_safe + reach_k from p0 then is at least d_safe from every rollout's sample.
    """
    speed2 = v0[0] * v0[0] + v0[1] * v0[1] + v0[2] * v0[2]
    for a in range(va.shape[0]):
        speed2 = max(speed2, va[a, 0] * va[a, 0] + va[a, 1] * va[a, 1] + va[a, 2] * va[a, 2])
    speed = math.sqrt(speed2)
    n_k, n_nb = nb_by_time.shape[0], nb_by_time.shape[1]
    near = np.empty((n_k, n_nb, 4))
    count = np.zeros(n_k, dtype=np.int64)
    for k in range(n_k):
        gate = d_safe + speed * tau[k]
        for j in range(n_nb):
            ex = nb_by_time[k, j, 0] - p0[0]
            ey = nb_by_time[k, j, 1] - p0[1]
            ez = nb_by_time[k, j, 2] - p0[2]
            if ex * ex + ey * ey + ez * ez < gate * gate:
                i = count[k]
                near[k, i, 0] = j
                near[k, i, 1:] = nb_by_time[k, j]
                count[k] = i + 1
    return near, count


@_jit
def _benign_ln_reward(n_k: int, kp: KernelParams) -> FloatArray:
    """ln|R_j(t)| (value eq. 3) for a conflict that has lasted t = n sample_dt, n = 0..K."""
    table = np.empty(n_k + 1)
    for n in range(n_k + 1):
        table[n] = math.log(-(kp.benign_base + kp.benign_rate * n * kp.sample_dt))
    return table


@_jit
def _rollout_into(
    p0: FloatArray, v0: FloatArray, va: FloatArray, tau: FloatArray, accel: float, path: FloatArray
) -> None:
    """actions eq. 2: ``path[k]`` = p(tau_k) of the velocity ramp from v0 to va."""
    dvx, dvy, dvz = va[0] - v0[0], va[1] - v0[1], va[2] - v0[2]
    dv = math.sqrt(dvx * dvx + dvy * dvy + dvz * dvz)
    t_ramp = dv / accel
    scale = 0.5 * accel / dv if dv > 1e-9 else 0.0  # half the acceleration vector, per unit dv
    for k in range(tau.shape[0]):
        ti = min(tau[k], t_ramp)
        rest = tau[k] - ti
        ramp = scale * ti * ti
        path[k, 0] = p0[0] + v0[0] * ti + ramp * dvx + va[0] * rest
        path[k, 1] = p0[1] + v0[1] * ti + ramp * dvy + va[1] * rest
        path[k, 2] = p0[2] + v0[2] * ti + ramp * dvz + va[2] * rest


@_jit
def _extension_loss(
    end: FloatArray,
    goal: FloatArray,
    n_k: int,
    regions: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    kp: KernelParams,
) -> float:
    """X_a <= 0: the mean goal term the extension (from the rollout's end straight at the goal
    at max speed) loses by halting before the first sample that would enter a region."""
    gx, gy, gz = goal[0] - end[0], goal[1] - end[1], goal[2] - end[2]
    length = math.sqrt(gx * gx + gy * gy + gz * gz)
    scale = 1.0 / length if length > 1e-9 else 0.0
    cap, done, lost = length, 0.0, 0.0  # how far it may go, has gone (m); value lost so far
    for i in range(kp.extension_n):
        free = min(kp.max_speed * kp.extension_dt * (i + 1), length)  # where it would be
        step = min(free, cap)
        if step > done:
            f = scale * step
            _, intruded = _region_hazard(
                end[0] + f * gx, end[1] + f * gy, end[2] + f * gz, n_k + i, regions, kp
            )
            if intruded > 0.0:
                cap = done  # blocked: it waits at the last free sample
            else:
                done = step
        if done < free:
            at, ideal = 1.0 - scale * done, 1.0 - scale * free  # offsets as fractions of g
            lost += _goal_term(-gx * at, -gy * at, -gz * at, kp) - _goal_term(
                -gx * ideal, -gy * ideal, -gz * ideal, kp
            )
    return lost / max(kp.extension_n, 1)


@_inline
def _in_altitude_band(z: float, z0: float, kp: KernelParams) -> bool:
    """E_a at one sample: not below the floor (above the ceiling) unless no lower (higher)
    than the aircraft is now, within ENVELOPE_SLACK_M (NED: z is down)."""
    below = z > kp.floor_down and z > z0 + ENVELOPE_SLACK_M
    above = z < kp.ceiling_down and z < z0 - ENVELOPE_SLACK_M
    return not (below or above)


@_inline
def _region_hazard(
    x: float,
    y: float,
    z: float,
    k: int,
    regions: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    kp: KernelParams,
) -> tuple[float, float]:
    """(worst region term, shield intrusion in m) at sample k (value eqs. 1, 4)."""
    center, pinv, sigma, sqrt_chi2, threshold = regions
    h, intrusion = 0.0, 0.0
    for r in range(center.shape[0]):
        d = _region_distance(x, y, z, center[r, k], pinv[r, k], sigma[r, k], sqrt_chi2[r])
        intrusion += max(0.0, threshold[r] - d)
        if d < kp.region_gate:
            h = min(h, kp.region_coef * math.exp(d * kp.region_ln_decay))
    return h, intrusion


@_inline
def _goal_term(x: float, y: float, z: float, kp: KernelParams) -> float:
    """Value eq. 1 of the goal, (x, y, z) being the offset from it."""
    d = math.sqrt(x * x + y * y + kp.goal_vertical_weight**2 * z * z)
    if d >= kp.goal_gate:
        return 0.0
    return kp.goal_coef * math.exp(d * kp.goal_ln_decay)
