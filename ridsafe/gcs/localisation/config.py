"""Configuration of the localisers (``pipeline.multilateration``, ``pipeline.imm``,
``pipeline.rssi_filter``, ``pipeline.authors_imm``): sections of
:class:`~ridsafe.gcs.pipeline_config.PipelineConfig`, whose module docstring says where the
defaults come from. Each validates itself in ``__post_init__`` and names the offending field.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ridsafe.common.checks import (
    check_covariance_diagonal,
    check_non_negative,
    check_positive,
    check_probability_vector,
)
from ridsafe.common.errors import FieldValueError

__all__ = ["AuthorsImmConfig", "ImmConfig", "Matrix2", "MultilaterationConfig", "RssiFilterConfig"]


@dataclass(frozen=True)
class MultilaterationConfig:
    """NLLS fixes over (x, y, z, Pt) (paper eq. (9)) or (x, y, z) at a tracked Pt."""

    min_receivers: int = 4
    #: 'trf' as the paper (scipy least_squares, bounded Pt); 'lm' scipy's MINPACK: the same
    #: minimum, about four times faster (``localisation/multilateration.py``).
    method: Literal["trf", "lm"] = "trf"
    max_nfev: int = 50
    tx_power_bounds_dbm: tuple[float, float] = (-50.0, 50.0)
    #: Fix covariance = s^2 (J^T J)^-1 with s = rssi_sigma_db ('rssi_sigma') or the residual
    #: standard error ('residuals', needs more receivers than unknowns), times this inflation.
    covariance_scale: Literal["rssi_sigma", "residuals"] = "rssi_sigma"
    covariance_inflation: float = 1.0
    #: Rejections: condition number of J^T J (columns scaled), largest position std, range of
    #: the solution from the receivers' centroid.
    max_condition: float = 1e10
    max_position_std_m: float = 1000.0
    max_range_m: float = 5000.0
    #: Solve position only at the tracked transmit power once its std is below this (dB);
    #: its uncertainty is propagated into the fix covariance. 0 disables.
    position_only_below_power_std_db: float = 1.0
    #: The tracked transmit power (fed by joint fixes) is a random walk of this variance/s.
    tx_power_q_db2_s: float = 1e-4

    def __post_init__(self) -> None:
        check_non_negative("tx_power_q_db2_s", self.tx_power_q_db2_s)
        if self.min_receivers < 4:
            raise FieldValueError("min_receivers", f"expected >= 4, got {self.min_receivers}")
        if self.max_nfev < 1:
            raise FieldValueError("max_nfev", f"expected >= 1, got {self.max_nfev}")
        low, high = self.tx_power_bounds_dbm
        if not low < high:
            raise FieldValueError("tx_power_bounds_dbm", f"expected low < high, got {low}, {high}")
        for name in ("covariance_inflation", "max_condition", "max_position_std_m", "max_range_m"):
            check_positive(name, getattr(self, name))
        check_non_negative(
            "position_only_below_power_std_db", self.position_only_below_power_std_db
        )


Matrix2 = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class ImmConfig:
    """The paper's IMM (appendix table): modes (CV, CA), ``transition[i][j] = P(mode j at k |
    mode i at k-1)`` per ``dt_s``; Q per ``dt_s``, scaled by the real interval; R per mode
    when ``measurement_covariance = 'paper'``, else each fix's own covariance."""

    dt_s: float = 0.25
    mu0: tuple[float, float] = (0.45, 0.55)
    transition: Matrix2 = ((0.98, 0.02), (0.16, 0.84))
    q_cv_diag: tuple[float, ...] = (2.0, 2.0, 2.0, 120.0, 120.0, 120.0)
    q_ca_diag: tuple[float, ...] = (4.0, 4.0, 4.0, 50.0, 50.0, 50.0, 20.0, 20.0, 20.0)
    r_cv_diag: tuple[float, float, float] = (400.0, 400.0, 400.0)
    r_ca_diag: tuple[float, float, float] = (50.0, 50.0, 50.0)
    #: 'fix': R = the multilateration's Jacobian covariance (ours); 'paper': R_CV / R_CA.
    measurement_covariance: Literal["fix", "paper"] = "fix"
    #: Variance given to the acceleration when a CV estimate is lifted into CA (authors: 64).
    lift_accel_var_m2_s4: float = 64.0
    #: NIS gate on fixes (chi2_3 at 99 %: 11.34, the authors'); 0 disables.
    gate_chi2: float = 11.34

    def __post_init__(self) -> None:
        check_positive("dt_s", self.dt_s)
        check_probability_vector("mu0", self.mu0)
        for i, row in enumerate(self.transition):
            check_probability_vector(f"transition[{i}]", row)
        check_covariance_diagonal("q_cv_diag", self.q_cv_diag, 6)
        check_covariance_diagonal("q_ca_diag", self.q_ca_diag, 9)
        check_covariance_diagonal("r_cv_diag", self.r_cv_diag, 3, strictly_positive=True)
        check_covariance_diagonal("r_ca_diag", self.r_ca_diag, 3, strictly_positive=True)
        check_positive("lift_accel_var_m2_s4", self.lift_accel_var_m2_s4)
        check_non_negative("gate_chi2", self.gate_chi2)


@dataclass(frozen=True)
class AuthorsImmConfig:
    """``estimator: authors_imm`` (``localisation/authors_imm.py``): the NLLS -> IMM as the
    authors' code ran it for the paper's tables (docs/paper_mode.md), with ``ImmConfig``'s dt,
    mu0, Q and R (R only for the fixes that start the track). Defaults: their values."""

    #: Initial variance of every state before the first fix.
    p0_var: float = 500.0
    #: Every mode's position covariance and the fused one: eigenvalues kept in these (m^2).
    pos_var_bounds_m2: tuple[float, float] = (4.0, 2500.0)
    #: A fix's covariance: eigenvalues kept in these (m^2).
    meas_var_bounds_m2: tuple[float, float] = (4.0, 6400.0)
    #: Mode-weighted NIS above ``soft_gate_chi2`` scales R by NIS / gate (at most
    #: ``downweight_max``); above ``reject_chi2`` the fix is dropped.
    soft_gate_chi2: float = 11.34
    reject_chi2: float = 60.0
    downweight_max: float = 16.0
    #: After an update with NIS above the gate, P *= 1 + gain (NIS / gate - 1), at most max.
    inflate_gain: float = 0.25
    inflate_max: float = 8.0
    #: The tracked transmit power follows each joint fix's by this gain, at most this step.
    tx_power_ema_gain: float = 0.2
    tx_power_max_step_db: float = 2.0
    max_speed_m_s: float = 120.0
    max_accel_m_s2: float = 40.0

    def __post_init__(self) -> None:
        for name in ("p0_var", "soft_gate_chi2", "reject_chi2", "max_speed_m_s", "max_accel_m_s2"):
            check_positive(name, getattr(self, name))
        for name in ("pos_var_bounds_m2", "meas_var_bounds_m2"):
            low, high = getattr(self, name)
            if not 0.0 < low <= high:
                raise FieldValueError(name, f"expected 0 < low <= high, got {low}, {high}")
        for name in ("downweight_max", "inflate_max"):
            if getattr(self, name) < 1.0:
                raise FieldValueError(name, f"expected >= 1, got {getattr(self, name)}")
        check_non_negative("inflate_gain", self.inflate_gain)
        if not 0.0 < self.tx_power_ema_gain <= 1.0:
            raise FieldValueError(
                "tx_power_ema_gain", f"expected (0, 1], got {self.tx_power_ema_gain}"
            )
        check_positive("tx_power_max_step_db", self.tx_power_max_step_db)


@dataclass(frozen=True)
class RssiFilterConfig:
    """Ours (``estimator: rssi_imm``): a Gaussian sum of IMMs (CV + CA, the paper's dt, mu0 and
    transition matrix from :class:`ImmConfig`) whose mode filters carry the transmit power as
    a state and update on every receiver's raw RSSI by iterated posterior linearisation.

    Kinematics: white acceleration (CV) and white jerk (CA). CV is the level-flight
    hypothesis: its vertical noise is ``vertical_noise_ratio`` of the horizontal, so altitude
    is a random walk of ``z_diffusion_m2_s`` and a vertical velocity cannot absorb the slow,
    nonlinear altitude corrections (with a free vertical velocity the altitude drifted by tens
    of metres and containment fell to 0.85 with 8 receivers in our Monte-Carlo). CA is the
    manoeuvre hypothesis in 3D (``ca_vertical_noise_ratio``): a spoofer climbing at 1 m/s keeps
    containment 0.96 with 8 receivers (0.65 when CA also held level flight); more vertical
    freedom lets spurious vertical velocity leak into CV through the mixing (0.3: level flight
    0.98 / climbing 0.96; 1.0: 0.97 / 0.97; 0.03: 0.98 / 0.92; 20 seeds).
    """

    q_cv_accel_m2_s3: float = 0.05
    q_ca_jerk_m2_s5: float = 0.05
    vertical_noise_ratio: float = 1e-3
    ca_vertical_noise_ratio: float = 0.3
    z_diffusion_m2_s: float = 0.5
    #: The transmit power: a random walk of this variance per second.
    q_tx_power_db2_s: float = 1e-4
    #: Horizontal acceleration variance of a CV estimate lifted into CA (vertical: times
    #: ``lift_vertical_ratio``).
    lift_accel_var_m2_s4: float = 1.0
    lift_vertical_ratio: float = 0.01
    max_iterations: int = 5
    #: Iterations stop when no position moves more than this.
    step_tol_m: float = 0.5
    #: A reception whose innovation exceeds this many standard deviations is dropped (unless
    #: more than a quarter of them would be: then the estimate is the suspect).
    reception_gate_sigma: float = 5.0
    #: Std of the receivers' reported positions, folded into each reception's variance.
    rx_position_sigma_m: float = 1.0
    #: An update uses at most this many receptions (of those the gate kept): the ones nearest
    #: the predicted position (the RSSI's gradient is 20 / (ln 10 d) dB per metre). 0: all,
    #: the default. The update's cost hardly depends on it (64 receivers 1.4 ms, 32 0.74
    #: ms), and the nearest ones can share one side of the transmitter: with 64 aircraft
    #: starting at three depots, 32 cost containment 0.989 -> 0.974 (min 0.93) and RMSE
    #: 11 -> 19 m (airborne: 0.996 -> 0.994, 5.7 -> 5.8 m; 3-4 seeds of synthetic traffic).
    max_receivers: int = 0
    #: The Gaussian sum (``localisation/gaussian_sum.py``): initial altitude hypotheses
    #: (moment-matched thirds of the 0-120 m band) and their std; one value gives a single IMM
    #: started with ``tracks.altitude_prior_std_m``.
    altitude_hypotheses_m: tuple[float, ...] = (20.0, 60.0, 100.0)
    hypothesis_std_m: float = 15.0
    #: Hypotheses lighter than this are dropped; a respawned altitude starts at the other.
    prune_weight: float = 1e-4
    respawn_weight: float = 1e-3
    #: The hypotheses' weights remember the evidence for about this long (s): each update the
    #: log weights shrink by exp(-dt / weight_memory_s) before the new likelihood multiplies
    #: them (``gaussian_sum.reweigh``). 0: plain Bayes, every old reception counts for ever
    #: (as before this key). 5 s, five location messages: on configs/paper.yaml, 30 seeds,
    #: containment 0.972 -> 0.990 (8 aircraft), 0.984 -> 0.993 (16), RMSE 24.5 -> 21.8 m and
    #: 16.0 -> 15.0 m, the mean region radius 62 -> 71 m and 39 -> 46 m (2 s: containment
    #: alike, radius 73 and 49 m); on the exponent-3 channel (robustness.yaml, 16 aircraft,
    #: seeds 0-9) 0.895 -> 0.953.
    weight_memory_s: float = 5.0
    #: Hypotheses closer than this (Mahalanobis distance of positions) merge.
    merge_distance: float = 0.5
    #: Split a hypothesis before an update whose curvature over it exceeds this (dB).
    split_nonlinearity_db: float = 0.5
    max_hypotheses: int = 6
    #: The ground's height in the GCS's ENU frame (m): a hypothesis that falls below it is
    #: reflected to its mirror image above it (``localisation/gaussian_sum.py``). None (the
    #: default): no ground. Set it where the frame's origin is on flat ground, as in the
    #: scenario configs (depots and delivery sites at z = 0).
    ground_z_enu_m: float | None = None
    #: Transmit power that changes every message (``localisation/power_jitter.py``): 'off'
    #: (the paper's assumption: one power per transmitter, a slow random walk) or 'adaptive'
    #: (the per-message variance estimated per track and added before each update, the track
    #: start profiling one power per message).
    tx_power_jitter: Literal["off", "adaptive"] = "off"
    #: 'adaptive': the estimate counts once above this (dB), and weighs the newest message so.
    tx_power_jitter_threshold_db: float = 2.0
    tx_power_jitter_forgetting: float = 0.2

    def __post_init__(self) -> None:
        for name in ("q_cv_accel_m2_s3", "q_ca_jerk_m2_s5", "lift_accel_var_m2_s4"):
            check_positive(name, getattr(self, name))
        for name in (
            "vertical_noise_ratio",
            "ca_vertical_noise_ratio",
            "lift_vertical_ratio",
            "z_diffusion_m2_s",
            "q_tx_power_db2_s",
        ):
            check_non_negative(name, getattr(self, name))
        if self.max_iterations < 1:
            raise FieldValueError("max_iterations", f"expected >= 1, got {self.max_iterations}")
        check_positive("step_tol_m", self.step_tol_m)
        check_non_negative("tx_power_jitter_threshold_db", self.tx_power_jitter_threshold_db)
        if not 0.0 < self.tx_power_jitter_forgetting <= 1.0:
            raise FieldValueError(
                "tx_power_jitter_forgetting",
                f"expected 0 < w <= 1, got {self.tx_power_jitter_forgetting}",
            )
        check_positive("reception_gate_sigma", self.reception_gate_sigma)
        check_non_negative("rx_position_sigma_m", self.rx_position_sigma_m)
        if self.max_receivers < 0:
            raise FieldValueError("max_receivers", f"expected >= 0, got {self.max_receivers}")
        self._check_sum()

    def _check_sum(self) -> None:
        k = len(self.altitude_hypotheses_m)
        if k == 0:
            raise FieldValueError("altitude_hypotheses_m", "expected at least one altitude")
        check_positive("hypothesis_std_m", self.hypothesis_std_m)
        if not 0.0 <= self.prune_weight < 0.5:
            raise FieldValueError("prune_weight", f"expected 0 <= w < 0.5, got {self.prune_weight}")
        if not (
            self.prune_weight < self.respawn_weight
            and self.respawn_weight * self.max_hypotheses < 1.0
        ):
            raise FieldValueError(
                "respawn_weight",
                f"expected prune_weight < w < 1/max_hypotheses, got {self.respawn_weight}",
            )
        check_non_negative("weight_memory_s", self.weight_memory_s)
        check_non_negative("merge_distance", self.merge_distance)
        check_non_negative("split_nonlinearity_db", self.split_nonlinearity_db)
        if self.max_hypotheses < k:
            raise FieldValueError(
                "max_hypotheses",
                f"expected >= {k} (the altitude hypotheses), got {self.max_hypotheses}",
            )
