"""Scoring every action's rollout at once: the planner's compiled hot loop.

For action a with rollout samples p_k = p_a(tau_k), k = 1..K (``actions`` eq. 2), and the
value terms of :mod:`ridsafe.companion.value` (eqs. 1-5)::

    G_a  = (1/K) sum_k V_goal(p_k) + X_a                    mean goal term along the rollout
    H_a  = min_k h_k + w (1/K) sum_k h_k                     worst hazard (w = 0 by default)
    h_k  = min( min_j V_benign(d_kj, t_kj), min_r V_region(d_r(p_k, tau_k)) )     value eq. 2
    d_kj = |p_k - (q_j + w_j (age_j + tau_k))|               neighbour j moved along its RID
                                                              velocity w_j, not frozen
    t_kj = dt #{i < k : d_ij < d_safe}                        conflict time so far (value eq. 3)
    I_a  = sum_k sum_r i_r(p_k, tau_k)                        shield intrusion (m), eqs. 4-5
    i_r  = max(0, m_r - s_r) outside, m_r + depth_r inside    ``value.region_intrusion_m``
    m_r  = min(max(d_r(p_0, 0), 1 m), margin)                 the shield's threshold
    s_r  = sigma_min (sqrt(Mahalanobis^2) - sqrt(chi2))       d_r = max(0, s_r); s_r < 0 inside
    depth_r = sigma_min (sqrt(chi2) - sqrt(m_h))              m_h: the horizontal offset's
                                                              Mahalanobis^2, horizontal marginal
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
and one inside the ellipsoid itself has no safe action. There I_a grows with the horizontal
depth, so the least intrusion leads out sideways rather than on through the region toward the
goal (as it would if every sample inside counted the same m_r); a way out up or down counts
once it is made. Sideways, because the regions are flat and can span the altitude band's
whole height: graded by the 3-D depth, whose shortest way out is then vertical, the fallback
sent the fleet to the band's edge and off its routes (docs/results/robustness.md). H_a is a
worst case over time rather than a mean: a close pass at one sample must not be averaged away
by the others.

The compiled code is :mod:`ridsafe.companion.planner_kernel`: it scores every action, or, given
the right-turn bias, only the actions that can still be chosen (a bound on the goal term, whose
argument is in that module). About 2 ms for 1,095 actions x 20 samples x 16 neighbours + 1
region when every neighbour stays within d_safe, well under 1 ms in a flight's typical scene
(bench/bench_planner.py).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ridsafe.companion.actions import ActionSet
from ridsafe.companion.planner_api import Neighbour, Region
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.companion.planner_kernel import KernelParams, score_all, score_bounded
from ridsafe.companion.scene_kernel import project_neighbours, project_regions

__all__ = ["KernelParams", "RolloutScores", "Scene", "build_scene", "score_actions"]

FloatArray = NDArray[np.float64]

# Covariance eigenvalues are floored here (m^2): a degenerate region still has a volume.
MIN_EIGENVALUE_M2 = 1.0
# The shield's threshold never drops below this (m): inside the ellipsoid nothing is safe.
MIN_SHIELD_M = 1.0


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
    how far every neighbour stays (inf when none can come within d_safe). ``n_scored``: how
    many actions were scored (``score_actions``)."""

    goal: FloatArray
    hazard: FloatArray
    intrusion_m: FloatArray
    envelope_ok: NDArray[np.bool_]
    min_separation_m: FloatArray
    n_scored: int


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
    within max(gate, margin) + v_max tau; a neighbour with a non-finite number never. Callers
    filter by policy (flagged, stale) first.
    """
    tau, tau_all = _rollout_times(cfg)  # (K,); (1 + K + K2,): now, rollout, extension
    nb_ids, nb_pos = _neighbours_near(now_s, p0_m, neighbours, tau, cfg)
    live = tuple(r for r in regions if r.valid_until_s >= now_s)
    if not live:  # the common case: none of the region arithmetic below
        k = tau_all.shape[0] - 1
        no_regions = np.zeros((0, k, 3)), np.zeros((0, k, 3, 3)), np.zeros((0, k))
        return Scene(tau, nb_ids, nb_pos, (), *no_regions, np.zeros(0), np.zeros(0))
    sqrt_chi2 = np.sqrt(np.array([r.chi2_threshold for r in live], dtype=np.float64))
    eigen = [_eigen(np.array(r.cov_ned_m2, dtype=np.float64).tobytes()) for r in live]
    center, pinv, sigma, d = project_regions(
        np.array([r.center_ned_m for r in live], dtype=np.float64),
        np.array([r.v_ned_m_s for r in live], dtype=np.float64),
        np.array([e[0] for e in eigen]),
        np.array([e[1] for e in eigen]),
        now_s - np.array([r.t_s for r in live], dtype=np.float64),
        tau_all,
        cfg.region_velocity_std_m_s,
        p0_m,
        sqrt_chi2,
    )
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


def _neighbours_near(
    now_s: float,
    p0_m: FloatArray,
    neighbours: tuple[Neighbour, ...],
    tau: FloatArray,
    cfg: PlannerConfig,
) -> tuple[tuple[str, ...], FloatArray]:
    """The neighbours that may matter and their positions q_j + w_j (now - t_j + tau_k) :
    ``(N, K, 3)``; a neighbour with a non-finite number is never kept (its distance is NaN
    or inf at every tau, which the gate's ``<`` refuses)."""
    if not neighbours:
        return (), np.zeros((0, tau.shape[0], 3))
    rows = np.array([(*n.p_ned_m, *n.v_ned_m_s, n.t_s) for n in neighbours], dtype=np.float64)
    pos, keep = project_neighbours(rows, now_s, tau, p0_m, cfg.d_safe_m, cfg.max_speed_m_s)
    if keep.all():
        return tuple(n.uas_id for n in neighbours), pos
    return tuple(n.uas_id for n, k in zip(neighbours, keep, strict=True) if k), pos[keep]


@functools.lru_cache(maxsize=256)
def _eigen(cov_bytes: bytes) -> tuple[FloatArray, FloatArray]:
    """Eigenvalues (floored) and eigenvectors of a region's covariance (the 3 x 3 float64
    array's bytes: -0.0 is not 0.0 here). Cached: a region is the same for many decisions
    of many aircraft, and eigh costs more than all the rest of a scene."""
    cov = np.frombuffer(cov_bytes, dtype=np.float64).reshape(3, 3)
    lam, vec = np.linalg.eigh(0.5 * (cov + cov.T))
    lam = np.maximum(lam, MIN_EIGENVALUE_M2)
    lam.setflags(write=False)
    vec.setflags(write=False)
    return lam, vec


def score_actions(
    p0_m: FloatArray,
    v0_m_s: FloatArray,
    goal_m: FloatArray,
    actions: ActionSet,
    scene: Scene,
    kp: KernelParams,
    right_turn_bias: float | None = None,
) -> RolloutScores:
    """Score the rollouts of ``actions`` (positions in the local NED frame): all of them, or,
    given ``choose_action``'s ``right_turn_bias``, only those that can still be chosen
    (``planner_kernel.score_bounded``; the others have H = -inf, I = +inf, separation NaN,
    G = -inf or exact, and ``choose_action`` picks what it would pick from all of them)."""
    n = len(actions)
    out = np.empty((4, n))
    ok = np.empty(n, dtype=np.bool_)
    args = (
        np.ascontiguousarray(p0_m, dtype=np.float64),
        np.ascontiguousarray(v0_m_s, dtype=np.float64),
        np.ascontiguousarray(goal_m, dtype=np.float64),
        np.ascontiguousarray(actions.velocity_ned_m_s),
    )
    hazards = (
        scene.tau_s,
        np.ascontiguousarray(scene.nb_pos_m.transpose(1, 0, 2)),
        (
            np.ascontiguousarray(scene.rg_center_m),
            np.ascontiguousarray(scene.rg_pinv_1_m2),
            np.ascontiguousarray(scene.rg_sigma_min_m),
            np.ascontiguousarray(scene.rg_sqrt_chi2),
            np.ascontiguousarray(scene.rg_threshold_m),
        ),
    )
    if right_turn_bias is None:
        score_all(*args, *hazards, kp, out, ok)
        scored = n
    else:
        bias = right_turn_bias * actions.turn_right
        scored = score_bounded(*args, bias, *hazards, kp, out, ok)
    return RolloutScores(out[0], out[1], out[2], ok, out[3], scored)
