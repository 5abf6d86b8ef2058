r"""The paper's NLLS -> IMM as the authors' code ran it (``pipeline.estimator: authors_imm``).

The paper's text describes a standard IMM with R_CV = 400 I and R_CA = 50 I (our
``nlls_imm``); the code behind its tables (docs/paper_mode.md, "Estimator") differs:

- Start: every claim heard before the track starts (the detection phase) gives a joint
  (x, y, z, Pt) fix started at the claimed position; the first sets both modes' positions
  (all states with variance ``p0_var``), the others update without prediction with the
  paper's R. The tracked power starts at the median of those fixes' Pt.
- Time: both mode filters are predicted on a fixed tick grid (``imm.dt_s``, 0.25 s) with Q per
  tick; a fix updates the state of the last tick (no prediction to its time). No mixing and no
  Markov step: the transition matrix has no effect; the mode probabilities only move by the
  measurement likelihoods, mu_j <- mu_j L_j / sum_i mu_i L_i.
- Measurement (>= 3 receivers): started from the fused estimate; with >= 4 receivers a joint
  solve moves the tracked power by ``Pt <- Pt + a clip(Pt_joint - Pt, +-step)`` (a, step =
  ``tx_power_ema_gain``, ``tx_power_max_step_db``) and its position starts a position-only
  solve at that power, which is the measurement z; R = its covariance by
  ``authors_fix_covariance`` with eigenvalues in ``meas_var_bounds_m2``.
- Gating: nu_j = z - H x_j, S_j = H P_j H^T + R, NIS = sum_j mu_j nu_j^T S_j^-1 nu_j. Above
  ``soft_gate_chi2`` (g) R is scaled by min(NIS / g, ``downweight_max``); above
  ``reject_chi2`` the fix is dropped. After a Joseph-form update, a mode whose NIS (at the
  scaled R) exceeds g has P scaled by min(1 + ``inflate_gain`` (NIS / g - 1), ``inflate_max``).
- Bounds: every mode's position covariance (after each step) and the fused one have their
  eigenvalues in ``pos_var_bounds_m2`` (std 2 - 50 m); speeds and accelerations are clipped;
  non-finite values are replaced and covariance entries kept within +-1e6 (the authors
  replace infinities by 1e6; clipping also finite runaways keeps numpy's linear algebra
  working where their code would carry them).

``predicted(t_s)`` advances the stored state over the ticks up to ``t_s`` (the tick schedule is
fixed, so asking twice at the same time gives the same answer) and fuses the modes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import LOSS_AT_1M_2400MHZ_DB
from ridsafe.gcs.localisation.authors_fix_covariance import authors_fix_covariance, eigclip
from ridsafe.gcs.localisation.multilateration import (
    predicted_rssi,
    solve_joint,
    solve_position_only,
)
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking.imm import Gaussian

FloatArray = NDArray[np.float64]

__all__ = ["AuthorsImm", "start"]

_POS_LIMIT_M = np.array([2000.0, 2000.0, 1000.0])
#: Covariance entries are kept within +-this (the authors' replacement for infinities).
_P_LIMIT = 1e6


def _transition(order: int, dt_s: float) -> FloatArray:
    """F of CV (order 2, 6 states) or CA (order 3, 9 states), blocks (p, v[, a])."""
    n = 3 * order
    F = np.eye(n)
    F[0:3, 3:6] = dt_s * np.eye(3)
    if order == 3:
        F[0:3, 6:9] = 0.5 * dt_s**2 * np.eye(3)
        F[3:6, 6:9] = dt_s * np.eye(3)
    return F


def _nis(nu: FloatArray, S: FloatArray) -> float:
    return float(nu @ np.linalg.solve(S, nu))


class AuthorsImm:
    """Two mode filters (CV, CA) on a tick grid; see the module docstring."""

    def __init__(
        self, cfg: PipelineConfig, p0_enu_m: FloatArray, t_s: float, power_dbm: float
    ) -> None:
        self.cfg = cfg
        a, c = cfg.authors_imm, cfg.imm
        self.dt_s = c.dt_s
        self.F = (_transition(2, c.dt_s), _transition(3, c.dt_s))
        self.Q = (np.diag(c.q_cv_diag), np.diag(c.q_ca_diag))
        self.R_paper = (np.diag(c.r_cv_diag), np.diag(c.r_ca_diag))
        self.x = [np.zeros(6), np.zeros(9)]
        self.P = [np.eye(6) * a.p0_var, np.eye(9) * a.p0_var]
        for j in range(2):
            self.x[j][:3] = p0_enu_m
            self._bound(j)
        self.mu = np.array(c.mu0, dtype=np.float64)
        self.t_tick_s = math.floor(t_s / c.dt_s + 1e-9) * c.dt_s
        self.power_dbm = power_dbm

    # --- the filter -----------------------------------------------------------------------

    def _bound(self, j: int) -> None:
        a = self.cfg.authors_imm
        # The authors' guards: the position block is clamped alone, so P can lose positive
        # definiteness and a mode the likelihoods have dropped can grow without bound.
        x = self.x[j] = np.nan_to_num(self.x[j], nan=0.0, posinf=0.0, neginf=0.0)
        self.P[j] = np.nan_to_num(self.P[j], nan=1e3, posinf=_P_LIMIT, neginf=-_P_LIMIT)
        np.clip(self.P[j], -_P_LIMIT, _P_LIMIT, out=self.P[j])
        x[:3] = np.clip(x[:3], -1.25 * _POS_LIMIT_M, 1.25 * _POS_LIMIT_M)
        x[3:6] = np.clip(x[3:6], -a.max_speed_m_s, a.max_speed_m_s)
        if x.size == 9:
            x[6:9] = np.clip(x[6:9], -a.max_accel_m_s2, a.max_accel_m_s2)
        self.P[j][:3, :3] = eigclip(self.P[j][:3, :3], *a.pos_var_bounds_m2)

    def _advance(self, t_s: float) -> None:
        while self.t_tick_s + self.dt_s <= t_s + 1e-9:
            for j in range(2):
                F = self.F[j]
                self.x[j] = F @ self.x[j]
                self.P[j] = F @ self.P[j] @ F.T + self.Q[j]
                self._bound(j)
            self.t_tick_s += self.dt_s

    def measure(self, z: FloatArray, R: FloatArray | None) -> bool:
        """Update both modes with the position ``z`` (R: the fix's covariance, or None for
        the paper's R per mode); False when the gate drops it."""
        a = self.cfg.authors_imm
        lo, hi = a.meas_var_bounds_m2
        Rs = [self.R_paper[j] if R is None else eigclip(R, lo, hi) for j in range(2)]
        nis = [_nis(z - self.x[j][:3], self.P[j][:3, :3] + Rs[j]) for j in range(2)]
        nis_mix = float(self.mu @ np.array(nis))
        if not math.isfinite(nis_mix) or nis_mix > a.reject_chi2:
            return False
        if nis_mix > a.soft_gate_chi2:
            scale = min(nis_mix / a.soft_gate_chi2, a.downweight_max)
            base = Rs[0] if R is not None else np.eye(3) * float(np.mean(np.diag(self.R_paper[0])))
            Rs = [eigclip(base * scale, lo, hi)] * 2
        log_like = np.zeros(2)
        for j in range(2):
            log_like[j], nis_j = self._kalman(j, z, Rs[j])
            if nis_j > a.soft_gate_chi2:
                self.P[j] *= min(
                    1.0 + a.inflate_gain * (nis_j / a.soft_gate_chi2 - 1.0), a.inflate_max
                )
            self._bound(j)
        w = np.log(np.maximum(self.mu, 1e-300)) + log_like
        w = np.exp(w - w.max())
        self.mu = w / w.sum()
        return True

    def _kalman(self, j: int, z: FloatArray, R: FloatArray) -> tuple[float, float]:
        """Joseph-form update of mode j; (log-likelihood, NIS) of the innovation."""
        x, P = self.x[j], self.P[j]
        n = x.size
        H = np.hstack((np.eye(3), np.zeros((3, n - 3))))
        nu = z - x[:3]
        S = P[:3, :3] + R
        S = 0.5 * (S + S.T)
        K = np.linalg.solve(S, P[:3, :]).T
        IKH = np.eye(n) - K @ H
        P_new = IKH @ P @ IKH.T + K @ R @ K.T
        self.x[j] = x + K @ nu
        self.P[j] = 0.5 * (P_new + P_new.T)
        nis = _nis(nu, S)
        _sign, logdet = np.linalg.slogdet(S)
        return -0.5 * (3.0 * math.log(2.0 * math.pi) + logdet + nis), nis

    def fused(self) -> Gaussian:
        """The mode-weighted (p, v) estimate, its position covariance bounded."""
        xs = [self.x[0], self.x[1][:6]]
        Ps = [self.P[0], self.P[1][:6, :6]]
        x = self.mu[0] * xs[0] + self.mu[1] * xs[1]
        P = sum(
            m * (Pj + np.outer(xj - x, xj - x)) for m, xj, Pj in zip(self.mu, xs, Ps, strict=True)
        )
        P = np.asarray(P, dtype=np.float64)
        P[:3, :3] = eigclip(P[:3, :3], *self.cfg.authors_imm.pos_var_bounds_m2)
        return Gaussian(x[None], P[None])

    # --- the Localiser protocol -----------------------------------------------------------

    def predicted(self, t_s: float) -> tuple[Gaussian, FloatArray]:
        self._advance(t_s)
        return self.fused(), self.mu.copy()

    def update(self, claim: ObservedClaim) -> bool:
        rx, rssi = claim.rx_p_enu_m, claim.rssi_dbm
        if rx.shape[0] < 3:
            return False
        self._advance(claim.t_s)
        start_p = np.clip(self.fused().x[0, :3], -_POS_LIMIT_M, _POS_LIMIT_M)
        m, a, sigma = self.cfg.multilateration, self.cfg.authors_imm, self.cfg.localisation_sigma_db
        if rx.shape[0] >= 4:
            joint = solve_joint(rx, rssi, np.r_[start_p, self.power_dbm], sigma, m)
            if joint.ok:
                step = np.clip(
                    joint.tx_power_dbm - self.power_dbm,
                    -a.tx_power_max_step_db,
                    a.tx_power_max_step_db,
                )
                low, high = m.tx_power_bounds_dbm
                self.power_dbm = float(
                    np.clip(self.power_dbm + a.tx_power_ema_gain * step, low, high)
                )
                start_p = joint.p_enu_m
        fix = solve_position_only(rx, rssi, start_p, self.power_dbm, 0.0, sigma, m)
        if not fix.ok:
            return False
        residual = rssi - predicted_rssi(fix.p_enu_m, self.power_dbm, rx, LOSS_AT_1M_2400MHZ_DB)
        return self.measure(fix.p_enu_m, authors_fix_covariance(rx, fix.p_enu_m, residual))


def _detection_fix(claim: ObservedClaim, cfg: PipelineConfig) -> tuple[FloatArray, float] | None:
    """The detection phase's joint fix of one claim, started at the claimed position."""
    rx, rssi = claim.rx_p_enu_m, claim.rssi_dbm
    if rx.shape[0] < max(4, cfg.multilateration.min_receivers):
        return None
    p0 = np.asarray(claim.claimed_p_enu_m, dtype=np.float64)
    pt0 = float(np.median(rssi - predicted_rssi(p0, 0.0, rx, LOSS_AT_1M_2400MHZ_DB)))
    fix = solve_joint(rx, rssi, np.r_[p0, pt0], cfg.localisation_sigma_db, cfg.multilateration)
    return (fix.p_enu_m, fix.tx_power_dbm) if fix.ok else None


def start(
    claims: Sequence[ObservedClaim], cfg: PipelineConfig, after_s: float = -math.inf
) -> tuple[AuthorsImm, int] | None:
    """Started from every joint fix among ``claims`` (all consumed); None without one."""
    fixes = [(c.t_s, f) for c in claims if c.t_s > after_s and (f := _detection_fix(c, cfg))]
    if not fixes:
        return None
    power = float(np.median([f[1] for _t, f in fixes]))
    # The filter is made at the alert (the newest claim): its ticks start there.
    localiser = AuthorsImm(cfg, fixes[0][1][0], max(c.t_s for c in claims), power)
    for _t, (p, _pt) in fixes[1:]:
        localiser.measure(p, None)
    return localiser, len(claims)
