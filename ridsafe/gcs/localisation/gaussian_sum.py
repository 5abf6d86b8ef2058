r"""Our estimator (the default, ``pipeline.estimator: rssi_imm``): a Gaussian sum of RSSI IMMs.

IMMs of CV + CA with the transmit power as a state, started (``start``) from the grid
posterior of ``initiation/grid.py``.

Each hypothesis h is an IMM (``tracking/imm.py``) whose mode filters update on the raw RSSI of every
receiver by iterated posterior linearisation (``rssi_update.py``). Why a sum: receivers flying
near the transmitter's height, or clustered at depots, leave several places (mirror
altitudes, a curve of positions) that explain the RSSI equally well; one Gaussian commits to
one of them and then reports a small covariance around the wrong place. The sum keeps them:

- weights follow Bayes with each IMM's predictive likelihood of the transmission, with a
  memory of ``weight_memory_s``::

      w_h <- w_h^f sum_j c_hj Lambda_hj,   f = exp(-dt / weight_memory_s),   normalised;

  below ``prune_weight`` a hypothesis goes. The fading is what lets a hypothesis the
  receptions cannot tell apart from the leading one win back weight: receivers flying in a
  layer below the transmitter hear it and its mirror image across their layer alike, so a
  respawned (or once unlucky) right altitude at weight 1e-3 stayed there under plain Bayes
  while the leading wrong one reported a tight covariance 40 m off (exponent-3 channel, 16
  aircraft climbing out of the depots under the spoofer: the moment-matched region missed the
  spoofer for 30 s). With the memory, weights equal in likelihood drift back together within
  a few ``weight_memory_s`` and the region covers both images; a hypothesis the receptions
  keep rejecting still goes (a likelihood ratio of e^-3 per 1 s claim holds it at e^-16.5
  with 5 s). ``tests/gcs/test_weight_memory.py``, ``tests/gcs/localisation/test_gaussian_sum.py``.

- output (region, track) is the moment-matched mixture::

      x = sum_h w_h x_h,   P = sum_h w_h (P_h + (x_h - x)(x_h - x)^T)

- split (Huber, Bailey, Durrant-Whyte, Hanebeck 2008, 3-component split of N(0, 1): weights
  0.2252, 0.5496, 0.2252, means -1.0575, 0, +1.0575; std sqrt(1 - sum w a^2) = 0.7045 so the
  split keeps the first two moments exactly) along the principal axis e
  of a hypothesis' position covariance before an update whose curvature over it is large,
  (20/ln10) lambda_max / (2 d_min^2) > ``split_nonlinearity_db`` (d_min: nearest receiver).
  Each mode's x moves by a P e / sqrt(e^T P e), its P loses (sum w a^2) P e e^T P / (e^T P e);
- merge two hypotheses whose positions are within ``merge_distance`` (Mahalanobis, summed
  covariances; the heavier survives with both weights), keep at most ``max_hypotheses``;
- respawn: an altitude of ``altitude_hypotheses_m`` farther than 2 ``hypothesis_std_m`` from
  every hypothesis gets one back (the heaviest, altitude reset, weight ``respawn_weight``), so
  an altitude the data have not excluded is never forgotten while far-off horizontal modes the
  data rule out are pruned for good;
- ground mirror (``ground_z_enu_m`` set): a hypothesis whose altitude falls below the ground
  is reflected to its mirror image above it (z -> 2 z_g - z, vertical velocity and
  acceleration negated, their covariance rows and columns with them). Receivers on the ground
  hear a transmitter at height h and at -h alike, so a spoofer hovering low over parked
  aircraft leaves the update a saddle at the ground between the two mirror images, where it
  settled a few metres below the ground with a tight covariance (hover at 10 m over 1 or 3
  parked receivers with 14 airborne, seeds 0-3: containment 0.77 without, 0.99 with; with
  the weights' memory, 0.87 without, two runs of eight at 0.48, and 0.997 with;
  ``tests/gcs/test_ground_mirror.py``). Nothing flies underground: the image below goes.

All hypotheses share one ``ImmModel`` and are stored as one batch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.initiation.grid import GridSeed, grid_posterior, init_windows, spread_m
from ridsafe.gcs.localisation import mixture_kernels
from ridsafe.gcs.localisation.power_jitter import PowerJitter
from ridsafe.gcs.localisation.rssi_update import (
    RssiMeasurement,
    gate_receptions,
    iplf_iterate,
    iplf_update,
    linearise,
    nearest_receivers,
)
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking import imm
from ridsafe.gcs.tracking.imm import Gaussian, ImmModel, ImmState, ModeUpdate
from ridsafe.gcs.tracking.motion_models import ACC, POS, VEL, MotionModel

FloatArray = NDArray[np.float64]

__all__ = [
    "GaussianSumLocaliser",
    "mirror_above_ground",
    "moment_match",
    "moment_match_reference",
    "rssi_imm_model",
    "seed_prior",
    "start",
]

PT = 9  # the transmit power's index in a CA-ordered state (then 6 in CV order)
_Z, _VZ, _AZ = 2, 5, 8
_HUBER = (
    (0.2252246249136750, -1.0575154134058),
    (0.5495507501726501, 0.0),
    (0.2252246249136750, 1.0575154134058),
)
# Each part's variance along e: 1 - sum w a^2, so the split keeps mean and covariance exactly
# (Huber et al.'s own 0.6716^2 = 0.451 would lose 4.5 % of the variance).
_HUBER_SHRINK = sum(w * a * a for w, a in _HUBER)
_MAX_GATED_FRACTION = 0.25


def rssi_imm_model(cfg: PipelineConfig) -> ImmModel:
    """CV (level flight: vertical noise scaled down) and CA (manoeuvres in 3D) with
    white-noise densities, an altitude random walk, the paper's transition matrix and dt,
    the transmit power a slow random walk."""
    f, c = cfg.rssi_filter, cfg.imm

    def mode(name: str, order: int, q: float, vertical_ratio: float) -> MotionModel:
        return MotionModel(
            name,
            order,
            q_psd=q,
            q_vertical_psd=q * vertical_ratio,
            z_diffusion_m2_s=f.z_diffusion_m2_s,
        )

    return ImmModel(
        models=(
            mode("CV", 2, f.q_cv_accel_m2_s3, f.vertical_noise_ratio),
            mode("CA", 3, f.q_ca_jerk_m2_s5, f.ca_vertical_noise_ratio),
        ),
        transition=np.asarray(c.transition, dtype=np.float64),
        dt_ref_s=c.dt_s,
        lift_accel_var=f.lift_accel_var_m2_s4 * np.array([1.0, 1.0, f.lift_vertical_ratio]),
        n_extra=1,
        extra_q=np.array([f.q_tx_power_db2_s]),
    )


def seed_prior(
    seed: GridSeed, cfg: PipelineConfig, z_std_m: float
) -> tuple[FloatArray, FloatArray]:
    """CA-ordered prior (p, v, a, Pt) of one grid seed: (x (10,), P (10, 10))."""
    t = cfg.tracks
    x = np.zeros(10)
    P = np.zeros((10, 10))
    x[0:2] = seed.p_xy_m
    x[_Z] = seed.altitude_m
    P[0:2, 0:2] = seed.cov_xy_m2
    P[_Z, _Z] = z_std_m**2
    P[VEL, VEL] = np.diag([t.init_speed_std_m_s**2] * 2 + [t.init_vertical_speed_std_m_s**2])
    P[ACC, ACC] = np.diag([t.init_accel_std_m_s2**2] * 2 + [t.init_vertical_accel_std_m_s2**2])
    x[PT] = seed.tx_power_dbm
    P[PT, PT] = max(seed.tx_power_var_db2, 0.01)
    return x, P


def moment_match(weights: FloatArray, g: Gaussian) -> Gaussian:
    """One Gaussian (batch of 1) with the moments of the weighted batch ``g`` (compiled:
    ``mixture_kernels.mixture_moments``)."""
    x, P = mixture_kernels.mixture_moments(
        np.ascontiguousarray(weights, dtype=np.float64),
        np.ascontiguousarray(g.x),
        np.ascontiguousarray(g.P),
    )
    return Gaussian(x[None, :], P[None, :, :])


def moment_match_reference(weights: FloatArray, g: Gaussian) -> Gaussian:
    """Numpy reference of :func:`moment_match`."""
    x = weights @ g.x
    d = g.x - x
    P = np.einsum("h,hij->ij", weights, g.P + d[:, :, None] * d[:, None, :])
    return Gaussian(x[None, :], imm.symmetrize(P)[None, :, :])


class GaussianSumLocaliser:
    def __init__(self, cfg: PipelineConfig, seeds: Sequence[GridSeed], t_s: float) -> None:
        self.cfg = cfg
        self.model = rssi_imm_model(cfg)
        f = cfg.rssi_filter
        z_std = f.hypothesis_std_m if len(seeds) > 1 else cfg.tracks.altitude_prior_std_m
        priors = [seed_prior(s, cfg, z_std) for s in seeds]
        prior = Gaussian(np.stack([p[0] for p in priors]), np.stack([p[1] for p in priors]))
        self.state = imm.initial_state(prior, 3, self.model, cfg.imm.mu0, t_s)
        self.weights = np.array([s.weight for s in seeds])
        #: When the weights last took a claim's likelihood (their memory fades from then:
        #: an update that fails has moved the state's time, not theirs).
        self.weighed_s = t_s
        self._prune()
        self.power_jitter: PowerJitter | None = None
        if f.tx_power_jitter == "adaptive":
            self.power_jitter = PowerJitter(
                f.tx_power_jitter_forgetting, f.tx_power_jitter_threshold_db
            )

    # --- output ---------------------------------------------------------------------------

    def predicted(self, t_s: float) -> tuple[Gaussian, FloatArray]:
        """(moment-matched fused estimate (batch of 1, CV order + Pt), mode probabilities)."""
        pred = imm.predict(self.state, self.model, t_s)
        return moment_match(self.weights, imm.merge(pred, self.model)), self.weights @ pred.mu

    @property
    def size(self) -> int:
        return self.state.size

    def shift_power(self, delta_db: float) -> None:
        """Add ``delta_db`` to every mode's transmit power (the last state element): the
        measurements' mapping changed by that much at this track's receivers."""
        modes = []
        for g in self.state.modes:
            x = g.x.copy()
            x[:, -1] += delta_db
            modes.append(Gaussian(x, g.P))
        self.state = ImmState(tuple(modes), self.state.mu, self.state.t_s)

    # --- update ---------------------------------------------------------------------------

    def update(self, claim: ObservedClaim) -> bool:
        f = self.cfg.rssi_filter
        meas = RssiMeasurement(
            claim.rx_p_enu_m, claim.rssi_dbm, self.cfg.localisation_sigma_db, f.rx_position_sigma_m
        )
        self.state = imm.predict(self.state, self.model, max(claim.t_s, self.state.t_s))
        fused = imm.merge(self.state, self.model)
        mixture = moment_match(self.weights, fused)
        if self.power_jitter is not None:
            fused, mixture = self._loosen_power(fused, mixture, meas)
        keep = gate_receptions(mixture, 6, meas, f.reception_gate_sigma, _MAX_GATED_FRACTION)
        meas = nearest_receivers(meas.subset(keep), mixture.x[0, :3], f.max_receivers)
        if self._split(fused, meas.rx):
            fused = imm.merge(self.state, self.model)
        out = self._iplf(fused, meas)
        if out is None:
            return False
        self.state, loglik = out
        elapsed_s = self.state.t_s - self.weighed_s  # never negative: the state only advances
        self.weights = reweigh(self.weights, loglik, elapsed_s, f.weight_memory_s)
        self.weighed_s = self.state.t_s
        self._prune()
        fused = imm.merge(self.state, self.model)
        if f.ground_z_enu_m is not None:
            below = fused.x[:, _Z] < f.ground_z_enu_m
            if np.any(below):
                self.state = mirror_above_ground(self.state, below, f.ground_z_enu_m)
                fused = imm.merge(self.state, self.model)
        fused = self._merge_close(fused)
        self._respawn(fused)
        return True

    def _loosen_power(
        self, fused: Gaussian, mixture: Gaussian, meas: RssiMeasurement
    ) -> tuple[Gaussian, Gaussian]:
        """Observe this message's common-mode innovation; add the estimated per-message power
        variance to every mode's power (``power_jitter.py``)."""
        assert self.power_jitter is not None
        idx = np.array([0, 1, 2, mixture.x.shape[1] - 1])
        u, C = mixture.x[0, idx], mixture.P[0][np.ix_(idx, idx)]
        self.power_jitter.observe(u, C, meas.rx, meas.rssi, meas.sigma_db)
        jitter = self.power_jitter.variance_db2
        if jitter <= 0.0:
            return fused, mixture
        modes = []
        for g in self.state.modes:
            P = g.P.copy()
            P[:, -1, -1] += jitter
            modes.append(Gaussian(g.x, P))
        self.state = ImmState(tuple(modes), self.state.mu, self.state.t_s)
        fused = imm.merge(self.state, self.model)
        return fused, moment_match(self.weights, fused)

    def _iplf(self, fused: Gaussian, meas: RssiMeasurement) -> tuple[ImmState, FloatArray] | None:
        """IPLF iterations once per hypothesis, on its mode-merged observed block (``fused``);
        both modes' updates then use that posterior's linearisation."""
        f = self.cfg.rssi_filter
        idx = np.array([0, 1, 2, fused.x.shape[1] - 1])
        u0, Puu = fused.x[:, idx], fused.P[:, idx[:, None], idx]
        mean, cov = iplf_iterate(u0, Puu, meas, f.max_iterations, f.step_tol_m)
        lin = linearise(meas, mean, cov)

        def updater(j: int, g: Gaussian) -> ModeUpdate:
            return iplf_update(g, g.x.shape[1] - 1, meas, lin)

        return imm.update(self.state, updater)

    def _prune(self) -> None:
        """Drop hypotheses lighter than ``prune_weight`` (the heaviest always stays)."""
        keep = np.flatnonzero(self.weights >= self.cfg.rssi_filter.prune_weight)
        if keep.shape[0] == 0:
            keep = np.array([int(np.argmax(self.weights))])
        if keep.shape[0] < self.size:
            self.state = self.state.take(keep)
        w = self.weights[keep]
        self.weights = w / w.sum()

    # --- mixture management ---------------------------------------------------------------

    def _split(self, fused: Gaussian, rx: FloatArray) -> bool:
        """Split the most curved hypotheses (module docstring); True if any was."""
        f = self.cfg.rssi_filter
        if f.split_nonlinearity_db <= 0.0 or f.max_hypotheses <= self.size:
            return False
        curvature, axis = mixture_kernels.split_curvature(
            np.ascontiguousarray(fused.x), np.ascontiguousarray(fused.P), np.ascontiguousarray(rx)
        )
        if not np.any(curvature > f.split_nonlinearity_db):
            return False
        room = (f.max_hypotheses - self.size) // 2
        order = [int(i) for i in np.argsort(-curvature) if curvature[i] > f.split_nonlinearity_db]
        chosen = order[:room]
        if not chosen:
            return False
        parts, weights = [], []
        for h in range(self.size):
            if h not in chosen:
                parts.append(self.state.take(np.array([h])))
                weights.append(self.weights[h])
                continue
            for w, a in _HUBER:
                parts.append(_split_along(self.state.take(np.array([h])), axis[h], a))
                weights.append(self.weights[h] * w)
        self.state = imm.concat(parts)
        self.weights = np.array(weights)
        return True

    def _merge_close(self, fused: Gaussian) -> Gaussian:
        """Merge hypotheses closer than ``merge_distance``, cap their number; the remaining
        hypotheses' fused estimates."""
        f = self.cfg.rssi_filter
        keep = np.arange(self.size)
        if f.merge_distance > 0.0 and self.size > 1:
            m2 = mixture_kernels.pair_mahalanobis2(
                np.ascontiguousarray(fused.x[:, POS]), np.ascontiguousarray(fused.P[:, POS, POS])
            )
            alive = np.ones(self.size, dtype=bool)
            for flat in np.argsort(m2, axis=None):
                a, b = np.unravel_index(int(flat), m2.shape)
                if m2[a, b] >= f.merge_distance**2:
                    break
                if not (alive[a] and alive[b]):
                    continue
                heavy, light = (a, b) if self.weights[a] >= self.weights[b] else (b, a)
                self.weights[heavy] += self.weights[light]
                alive[light] = False
            keep = np.flatnonzero(alive)
        if keep.shape[0] > f.max_hypotheses:
            keep = np.sort(keep[np.argsort(-self.weights[keep])[: f.max_hypotheses]])
        if keep.shape[0] < self.size:
            self.state = self.state.take(keep)
            self.weights = self.weights[keep] / self.weights[keep].sum()
            fused = Gaussian(fused.x[keep], fused.P[keep])
        return fused

    def _respawn(self, fused: Gaussian) -> None:
        f = self.cfg.rssi_filter
        layers = f.altitude_hypotheses_m
        if len(layers) < 2:
            return
        gaps = np.abs(fused.x[:, _Z, None] - np.asarray(layers)[None, :])
        if np.all(gaps.min(axis=0) <= 2.0 * f.hypothesis_std_m):
            return  # every altitude layer is covered (the usual case)
        altitudes = list(fused.x[:, _Z])
        clones: list[ImmState] = []
        for z in layers:
            if self.size + len(clones) >= f.max_hypotheses:
                break
            if min(abs(a - z) for a in altitudes) <= 2.0 * f.hypothesis_std_m:
                continue
            best = int(np.argmax(self.weights))
            clones.append(_reset_altitude(self.state.take(np.array([best])), z, self.cfg))
            altitudes.append(z)
        if clones:
            self.state = imm.concat([self.state, *clones])
            w_new = f.respawn_weight
            self.weights = np.r_[self.weights * (1.0 - w_new * len(clones)), [w_new] * len(clones)]


def reweigh(
    weights: FloatArray, loglik: FloatArray, elapsed_s: float, memory_s: float
) -> FloatArray:
    """The hypotheses' weights after an update (module docstring: weights): the evidence
    they held fades by ``exp(-elapsed_s / memory_s)`` in log space (``memory_s`` 0: kept
    whole, plain Bayes), then each is multiplied by its likelihood; normalised."""
    log_w = np.log(weights)
    if memory_s > 0.0:
        log_w = log_w * math.exp(-max(elapsed_s, 0.0) / memory_s)
    log_w = log_w + loglik
    w = np.exp(log_w - log_w.max())
    return w / w.sum()  # type: ignore[no-any-return]


def mirror_above_ground(state: ImmState, below: NDArray[np.bool_], ground_z_m: float) -> ImmState:
    """``state`` with the hypotheses ``below`` reflected in the plane z = ``ground_z_m``
    (module docstring: ground mirror)."""
    modes = []
    for g in state.modes:
        n = g.x.shape[1]
        sign = np.ones(n)
        sign[[i for i in (_Z, _VZ, _AZ) if i < n - 1]] = -1.0  # the power (last) stays
        x, P = g.x.copy(), g.P.copy()
        x[below] *= sign
        x[below, _Z] += 2.0 * ground_z_m
        P[below] *= np.outer(sign, sign)
        modes.append(Gaussian(x, P))
    return ImmState(tuple(modes), state.mu.copy(), state.t_s)


def _split_along(state: ImmState, e: FloatArray, a: float) -> ImmState:
    """One Huber component of ``state`` (a batch of 1) along the position direction ``e``."""
    modes = []
    for g in state.modes:
        col = g.P[0, :, :3] @ e  # P e
        var = float(e @ col[:3])
        x = g.x + a * col / math.sqrt(var)
        P = g.P - _HUBER_SHRINK * np.outer(col, col)[None] / var
        modes.append(Gaussian(x, imm.symmetrize(P)))
    return ImmState(tuple(modes), state.mu.copy(), state.t_s)


def _reset_altitude(state: ImmState, z: float, cfg: PipelineConfig) -> ImmState:
    """``state`` (batch of 1) with altitude N(z, hypothesis_std^2) and level flight,
    uncorrelated with the rest."""
    t, f = cfg.tracks, cfg.rssi_filter
    modes = []
    for g in state.modes:
        x, P = g.x.copy(), g.P.copy()
        n = x.shape[1]
        idx = [i for i in (_Z, _VZ, _AZ) if i < n - 1]
        x[:, idx] = 0.0
        x[:, _Z] = z
        P[:, idx, :] = 0.0
        P[:, :, idx] = 0.0
        P[:, _Z, _Z] = f.hypothesis_std_m**2
        P[:, _VZ, _VZ] = t.init_vertical_speed_std_m_s**2
        if _AZ in idx:
            P[:, _AZ, _AZ] = t.init_vertical_accel_std_m_s2**2
        modes.append(Gaussian(x, P))
    return ImmState(tuple(modes), state.mu.copy(), state.t_s)


def start(
    claims: Sequence[ObservedClaim], cfg: PipelineConfig, after_s: float = -math.inf
) -> tuple[GaussianSumLocaliser, int] | None:
    """The sum started from the first window of claims (oldest first, then shortest span first:
    ``tracks.init_spans_s``; each claim heard by ``tracks.init_min_receivers``) whose grid
    posterior is tight enough (``tracks.max_init_std_m``), and how many of ``claims`` that
    consumed; None when no window is. Only windows ending after ``after_s`` are tried."""
    f = cfg.rssi_filter
    spans_s = cfg.tracks.init_spans_s
    for used in init_windows(claims, cfg.tracks.init_min_receivers, after_s, spans_s):
        seeds = grid_posterior(
            used,
            f.altitude_hypotheses_m,
            cfg.localisation_sigma_db,
            per_message_power=f.tx_power_jitter == "adaptive",
        )
        limit = cfg.tracks.max_init_std_m
        if limit > 0 and spread_m(seeds) > limit:
            continue
        return GaussianSumLocaliser(cfg, seeds, used[-1].t_s), claims.index(used[-1]) + 1
    return None
