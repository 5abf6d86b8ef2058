r"""The paper's estimator (sec. 4.2; ``pipeline.estimator: nlls_imm``): NLLS fix -> IMM.

Per observed claim heard by >= 4 receivers, a multilateration fix (``multilateration.py``:
joint (x, y, z, Pt), or position-only at the tracked power once that is known to
``position_only_below_power_std_db``), then a linear IMM update with z = p_fix, H = [I3 0],
R = the fix's Jacobian covariance (``imm.measurement_covariance = 'fix'``) or the paper's
400 I / 50 I (``'paper'``), gated at chi2_3 99 % like the authors' code. Modes CV (6 states)
and CA (9) with the paper's Q (appendix table) over the real interval. The tracked power is a
scalar Kalman filter fed by the joint fixes' Pt and its variance. ``start`` starts it at the
first claim giving a joint fix (tried from the receivers' centroid and from the claimed
position; the lower residual wins), with the fix's position covariance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.common.pathloss import LOSS_AT_1M_2400MHZ_DB
from ridsafe.gcs.localisation.multilateration import (
    Fix,
    centroid_start,
    solve_joint,
    solve_position_only,
)
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking import imm
from ridsafe.gcs.tracking.imm import Gaussian, ImmModel, ImmState, ModeUpdate
from ridsafe.gcs.tracking.motion_models import ACC, POS, VEL, MotionModel

FloatArray = NDArray[np.float64]

__all__ = ["NllsImmLocaliser", "best_joint_fix", "start"]

_H_POS = np.hstack((np.eye(3), np.zeros((3, 6))))


def best_joint_fix(claim: ObservedClaim, cfg: PipelineConfig) -> Fix:
    """A joint fix from the receivers' centroid and from the claimed position; the better."""
    m = cfg.multilateration
    rx, z = claim.rx_p_enu_m, claim.rssi_dbm
    start_c = centroid_start(rx, z, LOSS_AT_1M_2400MHZ_DB)
    start_claim = np.r_[claim.claimed_p_enu_m, start_c[3]]
    fixes = [solve_joint(rx, z, s, cfg.localisation_sigma_db, m) for s in (start_c, start_claim)]
    ok = [f for f in fixes if f.ok]
    return min(ok, key=lambda f: f.rms_residual_db) if ok else fixes[0]


def fix_prior(fix: Fix, cfg: PipelineConfig) -> Gaussian:
    """CA-ordered prior (p, v, a) at a fix: its position and covariance, ``TrackConfig``'s
    velocity and acceleration uncertainty."""
    t = cfg.tracks
    x = np.zeros(9)
    P = np.zeros((9, 9))
    x[POS] = fix.p_enu_m
    P[POS, POS] = fix.cov_enu_m2
    P[VEL, VEL] = np.diag([t.init_speed_std_m_s**2] * 2 + [t.init_vertical_speed_std_m_s**2])
    P[ACC, ACC] = np.diag([t.init_accel_std_m_s2**2] * 2 + [t.init_vertical_accel_std_m_s2**2])
    return Gaussian(x[None], P[None])


def paper_imm_model(cfg: PipelineConfig) -> ImmModel:
    c = cfg.imm
    return ImmModel(
        models=(
            MotionModel("CV", 2, q_diag=c.q_cv_diag, dt_ref_s=c.dt_s),
            MotionModel("CA", 3, q_diag=c.q_ca_diag, dt_ref_s=c.dt_s),
        ),
        transition=np.asarray(c.transition, dtype=np.float64),
        dt_ref_s=c.dt_s,
        lift_accel_var=c.lift_accel_var_m2_s4,
    )


class NllsImmLocaliser:
    def __init__(self, cfg: PipelineConfig, fix: Fix, t_s: float) -> None:
        self.cfg = cfg
        self.model = paper_imm_model(cfg)
        self.state = imm.initial_state(fix_prior(fix, cfg), 3, self.model, cfg.imm.mu0, t_s)
        self.power = (fix.tx_power_dbm, fix.tx_power_var_db2)
        self.power_t_s = t_s
        self.n_fixes = 1
        self.last_fix: Fix = fix

    def predicted(self, t_s: float) -> tuple[Gaussian, FloatArray]:
        pred = imm.predict(self.state, self.model, t_s)
        return imm.merge(pred, self.model), pred.mu[0]

    def _tracked_power(self, t_s: float) -> tuple[float, float]:
        q = self.cfg.multilateration.tx_power_q_db2_s
        return self.power[0], self.power[1] + q * max(t_s - self.power_t_s, 0.0)

    def _fix(self, claim: ObservedClaim, prior: ImmState) -> Fix:
        m = self.cfg.multilateration
        p0 = imm.merge(prior, self.model).x[0, POS]
        pt, pt_var = self._tracked_power(claim.t_s)
        sigma = self.cfg.localisation_sigma_db
        rx, z = claim.rx_p_enu_m, claim.rssi_dbm
        limit = m.position_only_below_power_std_db
        if limit > 0 and pt_var <= limit**2:
            fix = solve_position_only(rx, z, p0, pt, pt_var, sigma, m)
            if fix.ok:
                return fix
        fix = solve_joint(rx, z, np.r_[p0, pt], sigma, m)
        if not fix.ok:
            fix = best_joint_fix(claim, self.cfg)
        if fix.ok:
            self._absorb_power(fix, claim.t_s)
        return fix

    def _absorb_power(self, fix: Fix, t_s: float) -> None:
        pt, var = self._tracked_power(t_s)
        k = var / (var + fix.tx_power_var_db2)
        self.power = (pt + k * (fix.tx_power_dbm - pt), (1.0 - k) * var)
        self.power_t_s = t_s

    def _measurement_cov(self, mode: int, fix: Fix) -> FloatArray:
        c = self.cfg.imm
        if c.measurement_covariance == "paper":
            return np.diag(c.r_cv_diag if mode == 0 else c.r_ca_diag)
        return fix.cov_enu_m2

    def update(self, claim: ObservedClaim) -> bool:
        prior = imm.predict(self.state, self.model, max(claim.t_s, self.state.t_s))
        self.state = prior
        fix = self._fix(claim, prior)
        self.last_fix = fix
        if not fix.ok:
            return False
        if self.cfg.imm.gate_chi2 > 0 and self.n_fixes >= 3 and self._gated(prior, fix):
            return False

        def updater(j: int, g: Gaussian) -> ModeUpdate:
            H = _H_POS[:, : g.x.shape[1]]
            return imm.kalman_update(g, fix.p_enu_m, H, self._measurement_cov(j, fix))[0]

        out = imm.update(prior, updater)
        if out is None:
            return False
        self.state = out[0]
        self.n_fixes += 1
        return True

    def _gated(self, prior: ImmState, fix: Fix) -> bool:
        """The authors' NIS gate on a fix against the fused prediction (R of the CV mode)."""
        fused = imm.merge(prior, self.model)
        S = fused.P[0, POS, POS] + self._measurement_cov(0, fix)
        nu = fix.p_enu_m - fused.x[0, POS]
        return float(nu @ np.linalg.solve(S, nu)) > self.cfg.imm.gate_chi2


def start(
    claims: Sequence[ObservedClaim], cfg: PipelineConfig, after_s: float = -math.inf
) -> tuple[NllsImmLocaliser, int] | None:
    """The localiser started at the first claim after ``after_s`` with a joint fix, and how
    many of ``claims`` (oldest first) that consumed; None when no claim gives one."""
    for i, claim in enumerate(claims):
        if claim.t_s <= after_s or claim.n_receivers < cfg.multilateration.min_receivers:
            continue
        fix = best_joint_fix(claim, cfg)
        if fix.ok:
            return NllsImmLocaliser(cfg, fix, claim.t_s), i + 1
    return None
