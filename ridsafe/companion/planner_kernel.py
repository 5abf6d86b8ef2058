"""The planner's compiled hot loop: every action's rollout scored against the scene.

The terms G_a, H_a, I_a, E_a and the closest approach are those of
:mod:`ridsafe.companion.planner_eval` (its docstring has the equations); this module holds the
numba code that computes them, in two ways that give the same choice:

- :func:`score_all` scores every action (the reference);
- :func:`score_bounded` scores only the actions that can still be chosen, in order of an
  upper bound on their value (below), and marks the others as not evaluated.

The goal term's bound. ``choose_action`` (:mod:`ridsafe.companion.planner`) picks
argmax J_a = (G_a + H_a) + b_a over the safe actions and compares it with the goal-only
argmax of G_a + b_a over the actions inside the altitude band. With d_k the weighted distance
of sample k to the goal, lo_a, hi_a and m_a their min, max and mean, and V(d) = c e^(-l d)
(c > 0, l > 0; 0 from the gate on) non-increasing in d and convex below the gate::

    (1/K) sum_k V(d_k)  <=  V(lo_a)                                        (V non-increasing)
    (1/K) sum_k V(d_k)  <=  chord of V over [lo_a, hi_a] at m_a            (convex, hi_a < gate)
                         =  (V(lo_a) (hi_a - m_a) + V(hi_a) (m_a - lo_a)) / (hi_a - lo_a)
    G_a  = (1/K) sum_k V(d_k) + X_a  <=  min of the two  =: U_a             (X_a <= 0)
    J_a  = (G_a + H_a) + b_a  <=  G_a + b_a  <=  U_a + b_a                  (H_a <= 0: every
                                                                            hazard reward < 0)

The hazard side: H_a <= h_a,1, the hazard of the first sample (H_a is the worst sample's
hazard plus a non-positive mean term), and h_a,1 is computed as the scoring computes it (no
conflict has lasted yet at the first sample). So::

    J_a  <=  (U_a + h_a,1) + b_a  =: B_a                 and     G_a + b_a  <=  U_a + b_a

U_a costs K square roots and two exps per action, h_a,1 one neighbour pass; G_a costs K + K2
exps and H_a K neighbour passes. The hover (the planner reads its intrusion and separation)
and the action of largest B_a are scored first; J* = the best J of a safe action scored so
far. Then the actions with B_a >= J* are scored in decreasing B_a until B_a < J*: that action
and every later one has J < J*, so the safe argmax cannot change. The goal-only argmax is
kept by scoring G_a alone (no hazards) for every action inside the altitude band whose
U_a + b_a is not below F* (the best G + b scored so far). Strict < keeps ties scored (argmax
takes the first of equal values). Once ``TIGHTEN_AFTER`` actions are scored (crowded
decisions, where h_a,1 is far above the hazard the best actions meet later), each next one is
first bounded again with the hazard of its middle and last samples as if no conflict had
lasted yet: ln|R(t)| does not decrease with t (the config refuses a reward that grows toward
zero), so that h is at least the scoring's h_a,k, and H_a <= h_a,k for every k (the mean
term is not positive). Raised by BOUND_SLACK of itself for exp's rounding, it replaces
h_a,1 in B_a where it is lower; an action whose tightened bound is below J* is left unscored
(its G_a as below if the goal-only argmax needs it). Floating point: every step is a
rounded +, x, /, sqrt or exp; rounding is monotone except exp (only faithfully rounded) and
the chord's own arithmetic, whose errors are a few ulps of V: U_a is inflated by 1e-9 of
itself and 1e-18 of V(0) (far above them) to cover it. With no safe action scored,
J* = -inf and every action is scored: the fallback (least intrusion) sees them all.
``tests/companion/test_planner_kernel.py`` checks the choice against ``score_all`` on random
scenes of every kind.

The kernel loops over actions x samples x (neighbours + regions) in compiled code, with no
(A, K, N) temporaries. Two things keep the neighbour loop short. Per sample, only neighbours
that some rollout can come within d_safe of are visited (every rollout stays within
max(|v0|, |v_a|) tau_k of p0). And since every benign reward is negative, the worst benign
term is one exp per sample, not one per neighbour::

    min_j R_j scale gamma^d_kj = -scale exp( max_j ( ln|R(t_kj)| + d_kj ln gamma ) )

with ln|R(t)| tabulated for t = 0, dt, ..., K dt.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.jit import jit, jit_inline
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.ramp_kernel import (
    ramp_axis,
    ramp_position,
    ramp_times,
    rollout_into,
    velocity_ramp,
)
from ridsafe.companion.region_kernel import horizontal_depth, region_signed_distance
from ridsafe.companion.value import source_coefficient

__all__ = ["KernelParams", "Regions", "score_all", "score_bounded"]

FloatArray = NDArray[np.float64]
#: (centre, P^-1, sqrt(lambda_min), sqrt(chi2), shield threshold) of a Scene's regions.
Regions = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]

# Rollouts may descend below the floor (climb above the ceiling) by this much: a hover from a
# descending state sinks v^2 / (2 a) < 0.5 m before it stops.
ENVELOPE_SLACK_M = 1.0
# U_a is inflated by this much relative to itself, and by its square relative to V(0): it
# covers exp's last-ulp non-monotonicity and the rounding of the sums and the chord.
BOUND_SLACK = 1e-9
#: Actions scored before each next one's bound is tightened by its later samples' hazard (a
#: decision that stops sooner pays nothing for it).
TIGHTEN_AFTER = 32


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
    benign_vertical_weight2: float
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
            cfg.benign_vertical_weight**2,
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


def score_all(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    regions: Regions,
    kp: KernelParams,
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> None:
    """Fill ``out[0..3, a]`` = G_a, H_a, I_a, min separation and ``ok[a]`` = E_a for every
    action ``va : (A, 3)``.

    ``nb_by_time : (K, N, 3)`` are the neighbours' positions, sample-major; ``regions`` as
    in ``Regions``.
    """
    _score_all_kernel(p0, v0, goal, va, tau, nb_by_time, regions, kp, out, ok)


def score_bounded(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    bias: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    regions: Regions,
    kp: KernelParams,
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> int:
    """``score_all`` for the actions that can still be chosen (module docstring), ``bias :
    (A,)`` being b_a; returns how many were scored. Every ``ok[a]`` is E_a; an action left
    unscored has H = -inf, I = +inf, separation NaN and G = -inf, or its exact G where the
    goal-only argmax needed it. The last action (the hover) is always scored."""
    return int(_score_bounded_kernel(p0, v0, goal, va, bias, tau, nb_by_time, regions, kp, out, ok))


@jit
def _score_all_kernel(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    regions: Regions,
    kp: KernelParams,
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> None:
    path = np.empty((tau.shape[0], 3))
    near, n_near = _near_neighbours(p0, v0, va, tau, nb_by_time, kp.d_safe)
    ln_reward = _benign_ln_reward(tau.shape[0], kp)
    conflicts = np.zeros(nb_by_time.shape[1], dtype=np.int64)
    for a in range(va.shape[0]):
        _score_action(a, p0, v0, goal, va, tau, near, n_near, ln_reward, regions, kp, path,
                      conflicts, out, ok)  # fmt: skip


@jit
def _score_bounded_kernel(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    bias: FloatArray,
    tau: FloatArray,
    nb_by_time: FloatArray,
    regions: Regions,
    kp: KernelParams,
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> int:
    n_a, n_k = va.shape[0], tau.shape[0]
    path = np.empty((n_k, 3))
    near, n_near = _near_neighbours(p0, v0, va, tau, nb_by_time, kp.d_safe)
    ln_reward = _benign_ln_reward(n_k, kp)
    conflicts = np.zeros(nb_by_time.shape[1], dtype=np.int64)
    goal_bound = np.empty(n_a)  # U_a + b_a
    key = np.empty(n_a)  # -((U_a + h_a,1) + b_a): ascending = most promising first
    u_h1 = np.empty((n_a, 2))  # U_a, h_a,1
    first = np.empty((n_a, 3))  # each rollout's first sample
    _goal_bounds(p0, v0, goal, va, tau, kp, goal_bound, ok, first)
    for a in range(n_a):
        conflicts[:] = 0
        x, y, z = first[a, 0], first[a, 1], first[a, 2]
        h_first = _hazard_at(x, y, z, 0, near, n_near, ln_reward, conflicts, regions, kp)[0]
        key[a] = -((goal_bound[a] + h_first) + bias[a])
        u_h1[a, 0], u_h1[a, 1] = goal_bound[a], h_first
        goal_bound[a] += bias[a]
        out[0, a], out[1, a], out[2, a], out[3, a] = -np.inf, -np.inf, np.inf, np.nan
    key[n_a - 1] = -np.inf  # the hover first, then the most promising other action: their
    best, best_free = -np.inf, -np.inf  # J* (and F*) bounds all others before any sort
    for a in (n_a - 1, int(np.argmin(key[: n_a - 1]))):  # (A >= 4: headings + 3)
        _score_action(a, p0, v0, goal, va, tau, near, n_near, ln_reward, regions, kp, path,
                      conflicts, out, ok)  # fmt: skip
        best, best_free = _update_best(a, out, ok, bias, best, best_free)
    done = np.zeros(n_a, dtype=np.bool_)
    done[n_a - 1] = done[int(np.argmin(key[: n_a - 1]))] = True
    rest = np.flatnonzero(-key >= best)  # all when no safe action yet (best = -inf)
    ln_none = np.full(ln_reward.shape[0], ln_reward[0])  # every count as no conflict time
    scored = 2
    for a in rest[np.argsort(key[rest])]:
        if -key[a] < best:
            break  # this bound and every later one: below J*
        if done[a]:
            continue
        if scored >= TIGHTEN_AFTER:
            h_later = _later_hazard_bound(p0, v0, va[a], tau, near, n_near, ln_none, conflicts,
                                          regions, kp)  # fmt: skip
            if (u_h1[a, 0] + min(u_h1[a, 1], h_later)) + bias[a] < best:
                continue  # below J* (its G, if the goal-only argmax needs it, below)
        scored += 1
        done[a] = True
        _score_action(a, p0, v0, goal, va, tau, near, n_near, ln_reward, regions, kp, path,
                      conflicts, out, ok)  # fmt: skip
        best, best_free = _update_best(a, out, ok, bias, best, best_free)
    for a in range(n_a):  # G alone where the goal-only argmax may still lie
        if ok[a] and not done[a] and not goal_bound[a] < best_free:
            rollout_into(p0, v0, va[a], tau, kp.accel, path)
            out[0, a] = _goal_score(path, goal, regions, kp)
    return int(np.count_nonzero(done))


@jit_inline
def _update_best(
    a: int, out: FloatArray, ok: NDArray[np.bool_], bias: FloatArray, best: float, free: float
) -> tuple[float, float]:
    """(J*, F*) after action a was scored."""
    if ok[a]:
        free = max(free, out[0, a] + bias[a])
        if out[2, a] <= 0.0:
            best = max(best, (out[0, a] + out[1, a]) + bias[a])
    return best, free


@jit_inline
def _goal_bounds(
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    kp: KernelParams,
    bound: FloatArray,
    ok: NDArray[np.bool_],
    first: FloatArray,
) -> None:
    """Of every action a: U_a (module docstring) in ``bound[a]``, E_a in ``ok[a]`` and its
    rollout's first sample in ``first[a]``. Sample-major, every action at once: the inner
    loop has no branch and reads contiguous columns, so the compiler vectorises it (the
    same arithmetic per action as one rollout at a time, the same bits; a quarter less time
    for the whole kernel, ``docs/results/benchmarks.md``). A goal term that is not a
    positive decay of distance has no such bound (+inf)."""
    n_a, n_k = va.shape[0], tau.shape[0]
    # Every action's ramp and end velocity, a contiguous column each (vector loads).
    dv, t_ramp, scale = np.empty((3, n_a)), np.empty(n_a), np.empty(n_a)
    v_end = np.ascontiguousarray(va.T)
    for a in range(n_a):
        ramp = velocity_ramp(v0, va[a], kp.accel)
        dv[0, a], dv[1, a], dv[2, a], t_ramp[a], scale[a] = ramp
        first[a, 0], first[a, 1], first[a, 2] = ramp_position(p0, v0, va[a], ramp, tau[0])
    lo, hi, total = np.full(n_a, np.inf), np.zeros(n_a), np.zeros(n_a)
    outside = np.zeros(n_a)  # samples outside the altitude band
    for k in range(n_k):
        for a in range(n_a):
            ti, rest, half_a_t2 = ramp_times(tau[k], t_ramp[a], scale[a])
            x = ramp_axis(p0[0], v0[0], v_end[0, a], dv[0, a], ti, rest, half_a_t2)
            y = ramp_axis(p0[1], v0[1], v_end[1, a], dv[1, a], ti, rest, half_a_t2)
            z = ramp_axis(p0[2], v0[2], v_end[2, a], dv[2, a], ti, rest, half_a_t2)
            d = _goal_distance(x - goal[0], y - goal[1], z - goal[2], kp)
            lo[a], hi[a], total[a] = min(lo[a], d), max(hi[a], d), total[a] + d
            outside[a] += 0.0 if _in_altitude_band(z, p0[2], kp) else 1.0
    for a in range(n_a):
        ok[a] = outside[a] == 0.0
        if not (kp.goal_coef > 0.0 and kp.goal_ln_decay < 0.0):
            bound[a] = np.inf
            continue
        value = _goal_value(lo[a], kp)
        if hi[a] < kp.goal_gate and hi[a] - lo[a] > 1e-6:  # the chord: V is convex below the gate
            mean = total[a] / n_k
            chord = (value * (hi[a] - mean) + _goal_value(hi[a], kp) * (mean - lo[a])) / (
                hi[a] - lo[a]
            )
            value = min(value, chord)
        bound[a] = value + BOUND_SLACK * (value + kp.goal_coef * BOUND_SLACK)


@jit_inline
def _score_action(
    a: int,
    p0: FloatArray,
    v0: FloatArray,
    goal: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    near: FloatArray,
    n_near: NDArray[np.int64],
    ln_reward: FloatArray,
    regions: Regions,
    kp: KernelParams,
    path: FloatArray,
    conflicts: NDArray[np.int64],
    out: FloatArray,
    ok: NDArray[np.bool_],
) -> None:
    """Fill ``out[0..3, a]`` = G_a, H_a, I_a, min separation and ``ok[a]`` = E_a; ``path``
    and ``conflicts`` are scratch."""
    n_k = tau.shape[0]
    rollout_into(p0, v0, va[a], tau, kp.accel, path)
    conflicts[:] = 0
    goal_sum, worst, hazard_sum, intrusion, min_d2 = 0.0, 0.0, 0.0, 0.0, np.inf
    envelope_ok = True
    for k in range(n_k):
        x, y, z = path[k, 0], path[k, 1], path[k, 2]
        goal_sum += _goal_term(x - goal[0], y - goal[1], z - goal[2], kp)
        envelope_ok = envelope_ok and _in_altitude_band(z, p0[2], kp)
        h, d2, intruded = _hazard_at(x, y, z, k, near, n_near, ln_reward, conflicts, regions, kp)
        worst, hazard_sum = min(worst, h), hazard_sum + h
        min_d2, intrusion = min(min_d2, d2), intrusion + intruded
    out[0, a] = goal_sum / n_k + _extension_loss(path[n_k - 1], goal, n_k, regions, kp)
    out[1, a] = worst + kp.hazard_mean_weight * hazard_sum / n_k
    out[2, a] = intrusion
    out[3, a] = math.sqrt(min_d2)
    ok[a] = envelope_ok


@jit_inline
def _goal_score(path: FloatArray, goal: FloatArray, regions: Regions, kp: KernelParams) -> float:
    """G_a of a rolled-out path: the mean goal term plus the extension's loss X_a (the sums
    of ``_score_action``, in its order: the same bits)."""
    n_k = path.shape[0]
    goal_sum = 0.0
    for k in range(n_k):
        goal_sum += _goal_term(path[k, 0] - goal[0], path[k, 1] - goal[1], path[k, 2] - goal[2], kp)
    return float(goal_sum / n_k + _extension_loss(path[n_k - 1], goal, n_k, regions, kp))


@jit_inline
def _hazard_at(
    x: float,
    y: float,
    z: float,
    k: int,
    near: FloatArray,
    n_near: NDArray[np.int64],
    ln_reward: FloatArray,
    conflicts: NDArray[np.int64],
    regions: Regions,
    kp: KernelParams,
) -> tuple[float, float, float]:
    """(h_k, squared distance to the nearest neighbour visited, shield intrusion) of sample
    k at (x, y, z); counts the conflicts (neighbours within d_safe) in ``conflicts``."""
    d_safe2 = kp.d_safe * kp.d_safe
    best, d2 = -np.inf, np.inf
    for i in range(n_near[k]):
        ex, ey, ez = x - near[k, i, 1], y - near[k, i, 2], z - near[k, i, 3]
        d2 = min(d2, ex * ex + ey * ey + ez * ez)
        e2 = ex * ex + ey * ey + kp.benign_vertical_weight2 * ez * ez  # the benign term's
        if e2 < d_safe2:
            j = int(near[k, i, 0])
            best = max(best, ln_reward[conflicts[j]] + math.sqrt(e2) * kp.benign_ln_decay)
            conflicts[j] += 1
    h = 0.0 if best == -np.inf else -kp.benign_scale * math.exp(best)
    h_region, intruded = _region_hazard(x, y, z, k, regions, kp)
    return min(h, h_region), d2, intruded


@jit
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


@jit
def _benign_ln_reward(n_k: int, kp: KernelParams) -> FloatArray:
    """ln|R_j(t)| (value eq. 3) for a conflict that has lasted t = n sample_dt, n = 0..K."""
    table = np.empty(n_k + 1)
    for n in range(n_k + 1):
        table[n] = math.log(-(kp.benign_base + kp.benign_rate * n * kp.sample_dt))
    return table


@jit_inline
def _later_hazard_bound(
    p0: FloatArray,
    v0: FloatArray,
    va: FloatArray,
    tau: FloatArray,
    near: FloatArray,
    n_near: NDArray[np.int64],
    ln_none: FloatArray,
    scratch: NDArray[np.int64],
    regions: Regions,
    kp: KernelParams,
) -> float:
    """An upper bound of H_a from its middle and last samples (module docstring): h there
    as if no conflict had lasted yet (``ln_none``: ln|R(0)| for every count), raised by
    BOUND_SLACK of itself."""
    ramp = velocity_ramp(v0, va, kp.accel)
    h = 0.0
    for k in (tau.shape[0] // 2, tau.shape[0] - 1):
        x, y, z = ramp_position(p0, v0, va, ramp, tau[k])
        scratch[:] = 0
        h = min(h, _hazard_at(x, y, z, k, near, n_near, ln_none, scratch, regions, kp)[0])
    return h * (1.0 - BOUND_SLACK)


@jit
def _extension_loss(
    end: FloatArray,
    goal: FloatArray,
    n_k: int,
    regions: Regions,
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


@jit_inline
def _in_altitude_band(z: float, z0: float, kp: KernelParams) -> bool:
    """E_a at one sample: not below the floor (above the ceiling) unless no lower (higher)
    than the aircraft is now, within ENVELOPE_SLACK_M (NED: z is down)."""
    below = (z > kp.floor_down) & (z > z0 + ENVELOPE_SLACK_M)  # & and |: no branch
    above = (z < kp.ceiling_down) & (z < z0 - ENVELOPE_SLACK_M)
    return not (below | above)


@jit_inline
def _region_hazard(
    x: float,
    y: float,
    z: float,
    k: int,
    regions: Regions,
    kp: KernelParams,
) -> tuple[float, float]:
    """(worst region term, shield intrusion in m) at sample k (value eqs. 1, 4)."""
    center, pinv, sigma, sqrt_chi2, threshold = regions
    h, intrusion = 0.0, 0.0
    for r in range(center.shape[0]):
        s = region_signed_distance(x, y, z, center[r, k], pinv[r, k], sigma[r, k], sqrt_chi2[r])
        if s >= 0.0:
            intrusion += max(0.0, threshold[r] - s)
        else:  # inside: the horizontal depth too (value.region_intrusion_m)
            depth = horizontal_depth(x, y, center[r, k], pinv[r, k], sigma[r, k], sqrt_chi2[r])
            intrusion += threshold[r] + depth
        d = max(0.0, s)
        if d < kp.region_gate:
            h = min(h, kp.region_coef * math.exp(d * kp.region_ln_decay))
    return h, intrusion


@jit_inline
def _goal_term(x: float, y: float, z: float, kp: KernelParams) -> float:
    """Value eq. 1 of the goal, (x, y, z) being the offset from it."""
    return _goal_value(_goal_distance(x, y, z, kp), kp)


@jit_inline
def _goal_distance(x: float, y: float, z: float, kp: KernelParams) -> float:
    """The goal term's weighted distance (m), (x, y, z) being the offset from the goal."""
    return math.sqrt(x * x + y * y + kp.goal_vertical_weight**2 * z * z)


@jit_inline
def _goal_value(d: float, kp: KernelParams) -> float:
    """Value eq. 1 of the goal at (weighted) distance d (m): non-increasing in d."""
    if d >= kp.goal_gate:
        return 0.0
    return kp.goal_coef * math.exp(d * kp.goal_ln_decay)
