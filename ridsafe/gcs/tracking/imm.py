r"""Interacting multiple model (IMM) estimator over modes of different state sizes, batched.

Convention (tested with an asymmetric matrix): ``transition[i, j] = P(mode j at k | mode i
at k-1)``; rows sum to 1. It is given per reference step dt_ref; over an interval dt the
chain moves by Pi^(dt / dt_ref) (a fractional power through the eigen-decomposition when that
is real and stochastic, as for every two-mode matrix with Pi_01 + Pi_10 < 1; the nearest
integer power otherwise).

One cycle (Bar-Shalom, Li, Kirubarajan 2001, sec. 11.6.6), with Pi over the interval:

1. predicted mode probabilities   c_j = sum_i Pi_ij mu_i
2. mixing weights                 w_ij = Pi_ij mu_i / c_j
3. mixed start of mode j          x0_j = sum_i w_ij T_j(x_i),
                                  P0_j = sum_i w_ij (T_j(P_i) + (T_j(x_i) - x0_j)(..)^T)
   where T_j converts an estimate into mode j's state space (``motion_models.convert``:
   lift CV -> CA with zero acceleration of stated variance, truncate CA -> CV)
4. mode-matched prediction        x_j = F_j x0_j,  P_j = F_j P0_j F_j^T + Q_j   (F, Q over dt)
5. mode-matched update            any updater returning (x, P, log Lambda_j)
6. mode probabilities             mu_j = c_j Lambda_j / sum_l c_l Lambda_l   (in logs)
7. fused output (paper eq. (6), (7)), in the common CV space:
                                  x = sum_j mu_j x_j,  P = sum_j mu_j (P_j + (x_j - x)(x_j - x)^T)

Every array carries a leading batch axis of H independent IMMs (the hypotheses of a
Gaussian sum share one model): x (H, n), P (H, n, n), mu (H, M). A linear Kalman update for
fixes (paper eq. (3), H = [I3 0]) is here too, Joseph form, with log N(nu; 0, S).

``predict`` and ``merge`` run compiled kernels (``imm_kernels.py``; they run every cycle for
every track); ``mix``, ``predict_reference`` and ``merge_reference`` are the same equations
in plain numpy, kept as the tests' oracle.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ridsafe.gcs.tracking import imm_kernels
from ridsafe.gcs.tracking.motion_models import ACC, MotionModel, conversion_rows, convert

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.int64]

__all__ = [
    "Gaussian",
    "ImmModel",
    "ImmState",
    "ModeUpdate",
    "initial_state",
    "kalman_update",
    "merge",
    "merge_reference",
    "mix",
    "predict",
    "predict_reference",
    "symmetrize",
    "transition_over",
    "update",
]

_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True, eq=False)
class Gaussian:
    x: FloatArray  # (H, n)
    P: FloatArray  # (H, n, n)


@dataclass(frozen=True, eq=False)
class ModeUpdate:
    """A mode filter's posterior and the log-likelihood of the measurement, per batch item;
    ``P`` symmetric (an updater symmetrises what it computes)."""

    x: FloatArray  # (H, n)
    P: FloatArray  # (H, n, n)
    log_likelihood: FloatArray  # (H,)


@dataclass(frozen=True, eq=False)
class ImmModel:
    """The modes, their Markov chain (per ``dt_ref_s``) and how estimates move between them.

    ``n_extra`` trailing states (e.g. the transmit power) follow every mode's kinematics, as
    random walks with variance ``extra_q`` per second.
    """

    models: tuple[MotionModel, ...]
    transition: FloatArray  # (M, M)
    dt_ref_s: float
    lift_accel_var: float | FloatArray  # one value, or (3,) per axis E, N, U
    n_extra: int = 0
    extra_q: FloatArray | None = None  # (n_extra,)
    _matrices: dict[tuple[int, float], tuple[FloatArray, FloatArray]] = field(
        default_factory=dict, compare=False, repr=False
    )
    _conversions: dict[tuple[int, ...], tuple[IndexArray, FloatArray]] = field(
        default_factory=dict, compare=False, repr=False
    )
    _steps: dict[float, tuple[FloatArray, tuple[FloatArray, ...], tuple[FloatArray, ...]]] = field(
        default_factory=dict, compare=False, repr=False
    )

    @property
    def orders(self) -> tuple[int, ...]:
        return tuple(m.order for m in self.models)

    def dim(self, mode: int) -> int:
        return self.models[mode].kin_dim + self.n_extra

    def matrices(self, mode: int, dt_s: float) -> tuple[FloatArray, FloatArray]:
        """(F, Q) of a mode's whole state (kinematics, then the extra random walks), cached
        per interval (treat them as read-only)."""
        dt_s = round(dt_s, 9)  # the key, and what is computed: the same whatever came first
        key = (mode, dt_s)
        hit = self._matrices.get(key)
        if hit is not None:
            return hit
        model = self.models[mode]
        k, n = model.kin_dim, self.dim(mode)
        F_k, Q_k = model.matrices(dt_s)
        F = np.eye(n)
        Q = np.zeros((n, n))
        F[:k, :k] = F_k
        Q[:k, :k] = Q_k
        if self.n_extra and self.extra_q is not None:
            Q[k:, k:] = np.diag(self.extra_q * dt_s)
        if len(self._matrices) > 4096:
            self._matrices.clear()
        self._matrices[key] = (F, Q)
        return F, Q

    def over(
        self, dt_s: float
    ) -> tuple[FloatArray, tuple[FloatArray, ...], tuple[FloatArray, ...]]:
        """(Pi over ``dt_s``, every mode's F, every mode's Q), cached per interval."""
        key = dt_s = round(dt_s, 9)  # as ``matrices``
        hit = self._steps.get(key)
        if hit is not None:
            return hit
        FQ = [self.matrices(j, dt_s) for j in range(len(self.models))]
        Pi = np.ascontiguousarray(transition_over(self.transition, dt_s, self.dt_ref_s))
        out = (Pi, tuple(F for F, _ in FQ), tuple(Q for _, Q in FQ))
        if len(self._steps) > 4096:
            self._steps.clear()
        self._steps[key] = out
        return out

    def conversions(self, to_orders: tuple[int, ...]) -> tuple[IndexArray, FloatArray]:
        """Every mode's conversion into each kinematic order of ``to_orders`` as index maps
        (``motion_models.conversion_rows``, padded with -1): src (T, M, n_max), and the
        lifted accelerations' variances lift_var (T, n_max), for ``imm_kernels``."""
        hit = self._conversions.get(to_orders)
        if hit is not None:
            return hit
        dims = [3 * o + self.n_extra for o in (*to_orders, *(m.order for m in self.models))]
        n_max = max(dims)
        src = np.full((len(to_orders), len(self.models), n_max), -1, dtype=np.int64)
        lift_var = np.zeros((len(to_orders), n_max))
        accel = np.broadcast_to(np.asarray(self.lift_accel_var, dtype=np.float64), (3,))
        for t, order in enumerate(to_orders):
            for i, model in enumerate(self.models):
                rows = conversion_rows(model.order, order, self.n_extra)
                src[t, i, : rows.shape[0]] = rows
            if order == 3:
                lift_var[t, ACC] = accel
        self._conversions[to_orders] = (src, lift_var)
        return src, lift_var


@dataclass(frozen=True, eq=False)
class ImmState:
    modes: tuple[Gaussian, ...]
    mu: FloatArray  # (H, M) mode probabilities
    t_s: float

    @property
    def size(self) -> int:
        return int(self.mu.shape[0])

    def take(self, index: NDArray[np.int64]) -> ImmState:
        """The batch items ``index`` (repeats allowed)."""
        modes = tuple(Gaussian(g.x[index], g.P[index]) for g in self.modes)
        return ImmState(modes, self.mu[index], self.t_s)


def concat(states: Sequence[ImmState]) -> ImmState:
    """Stack IMMs of one model and time along the batch axis."""
    n_modes = len(states[0].modes)
    modes = tuple(
        Gaussian(
            np.concatenate([s.modes[j].x for s in states]),
            np.concatenate([s.modes[j].P for s in states]),
        )
        for j in range(n_modes)
    )
    return ImmState(modes, np.concatenate([s.mu for s in states]), states[0].t_s)


def symmetrize(P: FloatArray) -> FloatArray:
    out: FloatArray = 0.5 * (P + np.swapaxes(P, -1, -2))
    return out


_TRANSITION_CACHE: dict[tuple[bytes, float], FloatArray] = {}


def transition_over(transition: FloatArray, dt_s: float, dt_ref_s: float) -> FloatArray:
    """Pi^(dt / dt_ref): the mode chain over a real interval."""
    steps = round(dt_s / dt_ref_s, 9)  # the key, and what is computed (ImmModel.matrices)
    if abs(steps - 1.0) < 1e-9:
        return transition
    if steps <= 0.0:
        return np.eye(transition.shape[0])
    key = (transition.tobytes(), steps)
    hit = _TRANSITION_CACHE.get(key)
    if hit is not None:
        return hit
    out = np.linalg.matrix_power(transition, round(steps))
    w, V = np.linalg.eig(transition)
    if np.all(np.abs(w.imag) < 1e-12) and np.all(w.real > 0.0):
        frac = (V.real * w.real**steps) @ np.linalg.inv(V.real)
        if np.all(frac > -1e-12):
            frac = np.clip(frac, 0.0, None)
            out = frac / frac.sum(axis=1, keepdims=True)
    if len(_TRANSITION_CACHE) > 4096:
        _TRANSITION_CACHE.clear()
    _TRANSITION_CACHE[key] = out
    return out


def mix(
    state: ImmState, model: ImmModel, Pi: FloatArray
) -> tuple[tuple[Gaussian, ...], FloatArray]:
    """Steps 1-3: the mixed start of every mode and the predicted mode probabilities."""
    c = np.maximum(state.mu @ Pi, 1e-300)  # (H, M)
    weights = Pi[None, :, :] * state.mu[:, :, None] / c[:, None, :]  # w[h, i, j]
    mixed: list[Gaussian] = []
    for j, target in enumerate(model.models):
        conv = [
            convert(g.x, g.P, model.models[i].order, target.order, model.lift_accel_var)
            for i, g in enumerate(state.modes)
        ]
        x0 = sum(
            (weights[:, i, j, None] * xi for i, (xi, _) in enumerate(conv)),
            np.zeros((state.size, model.dim(j))),
        )
        P0 = np.zeros((state.size, model.dim(j), model.dim(j)))
        for i, (xi, P_i) in enumerate(conv):
            d = xi - x0
            P0 += weights[:, i, j, None, None] * (P_i + d[:, :, None] * d[:, None, :])
        mixed.append(Gaussian(x0, symmetrize(P0)))
    return tuple(mixed), c / c.sum(axis=1, keepdims=True)


def predict(state: ImmState, model: ImmModel, t_s: float) -> ImmState:
    """Steps 1-4 to time ``t_s`` (returns ``state`` itself when ``t_s`` is not later), by the
    compiled kernel (``imm_kernels.predict_batch``; :func:`predict_reference` in numpy)."""
    dt = t_s - state.t_s
    if dt <= 0.0:
        return state
    Pi, Fs, Qs = model.over(dt)
    src, lift_var = model.conversions(model.orders)
    H = state.size
    xs = tuple([np.empty((H, F.shape[0])) for F in Fs])
    Ps = tuple([np.empty((H, F.shape[0], F.shape[0])) for F in Fs])
    mu = np.empty_like(state.mu)
    imm_kernels.predict_batch(
        tuple([np.ascontiguousarray(g.x) for g in state.modes]),
        tuple([np.ascontiguousarray(g.P) for g in state.modes]),
        np.ascontiguousarray(state.mu),
        Pi,
        src,
        lift_var,
        Fs,
        Qs,
        xs,
        Ps,
        mu,
    )
    return ImmState(tuple([Gaussian(x, P) for x, P in zip(xs, Ps, strict=True)]), mu, t_s)


def predict_reference(state: ImmState, model: ImmModel, t_s: float) -> ImmState:
    """Numpy reference of :func:`predict`: ``mix``, then every mode's F and Q."""
    dt = t_s - state.t_s
    if dt <= 0.0:
        return state
    mixed, c = mix(state, model, transition_over(model.transition, dt, model.dt_ref_s))
    modes = []
    for j, g in enumerate(mixed):
        F, Q = model.matrices(j, dt)
        modes.append(Gaussian(g.x @ F.T, symmetrize(F @ g.P @ F.T + Q)))
    return ImmState(tuple(modes), c, t_s)


def update(
    state: ImmState, updater: Callable[[int, Gaussian], ModeUpdate | None]
) -> tuple[ImmState, FloatArray] | None:
    """Steps 5-6 with ``updater(mode, prior)``; None when the updater rejects any mode.

    Also returns each item's log-likelihood of the measurement under its whole IMM,
    log sum_j c_j Lambda_j (H,), for weighting IMMs against each other.
    """
    results: list[ModeUpdate] = []
    for j, g in enumerate(state.modes):
        res = updater(j, g)
        if res is None:
            return None
        results.append(res)
    log_lik = np.stack([r.log_likelihood for r in results], axis=1)  # (H, M)
    mu, total = imm_kernels.mode_probabilities(np.ascontiguousarray(state.mu), log_lik)
    modes = tuple([Gaussian(r.x, r.P) for r in results])
    return ImmState(modes, mu, state.t_s), total


def merge(state: ImmState, model: ImmModel, order: int = 2) -> Gaussian:
    """Step 7 (paper eq. (6), (7)) per batch item: the fused estimate in the space of
    kinematic ``order`` (default CV: position, velocity, then the extra states); by the
    compiled kernel (``imm_kernels.merge_batch``; :func:`merge_reference` in numpy)."""
    src, lift_var = model.conversions((order,))
    n = 3 * order + model.n_extra
    x = np.empty((state.size, n))
    P = np.empty((state.size, n, n))
    imm_kernels.merge_batch(
        tuple([np.ascontiguousarray(g.x) for g in state.modes]),
        tuple([np.ascontiguousarray(g.P) for g in state.modes]),
        np.ascontiguousarray(state.mu),
        src[0],
        lift_var[0],
        x,
        P,
    )
    return Gaussian(x, P)


def merge_reference(state: ImmState, model: ImmModel, order: int = 2) -> Gaussian:
    """Numpy reference of :func:`merge`."""
    conv = [
        convert(g.x, g.P, model.models[j].order, order, model.lift_accel_var)
        for j, g in enumerate(state.modes)
    ]
    mu = state.mu
    x = sum((mu[:, j, None] * xj for j, (xj, _) in enumerate(conv)), np.zeros_like(conv[0][0]))
    P = np.zeros_like(conv[0][1])
    for j, (xj, Pj) in enumerate(conv):
        d = xj - x
        P += mu[:, j, None, None] * (Pj + d[:, :, None] * d[:, None, :])
    return Gaussian(x, symmetrize(P))


def kalman_update(
    prior: Gaussian, z: FloatArray, H: FloatArray, R: FloatArray
) -> tuple[ModeUpdate, FloatArray]:
    """Linear update of a batch, Joseph form: K = P H^T S^-1,
    P+ = (I - K H) P (I - K H)^T + K R K^T; also the NIS nu^T S^-1 nu (H,).

    ``z`` (m,) or (B, m); ``H`` (m, n); ``R`` (m, m) or (B, m, m).
    """
    x, P = prior.x, prior.P
    nu = z - x @ H.T  # (B, m)
    PHt = P @ H.T  # (B, n, m)
    S = symmetrize(H @ PHt + R)
    L = np.linalg.cholesky(S)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)  # (B, n, m)
    IKH = np.eye(x.shape[-1]) - K @ H
    P_new = IKH @ P @ np.swapaxes(IKH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    white = np.linalg.solve(L, nu[..., None])[..., 0]
    nis = np.sum(white * white, axis=-1)
    log_det = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    loglik = -0.5 * (nis + log_det + nu.shape[-1] * _LOG_2PI)
    x_new = x + (K @ nu[..., None])[..., 0]
    return ModeUpdate(x_new, symmetrize(P_new), loglik), nis


def initial_state(
    prior: Gaussian, prior_order: int, model: ImmModel, mu0: Sequence[float], t_s: float
) -> ImmState:
    """Every mode of every batch item starts from ``prior`` (batched, in kinematic
    ``prior_order``), converted to the mode's space."""
    modes = tuple(
        Gaussian(*convert(prior.x, prior.P, prior_order, m.order, model.lift_accel_var))
        for m in model.models
    )
    mu = np.asarray(mu0, dtype=np.float64)
    return ImmState(modes, np.tile(mu / mu.sum(), (prior.x.shape[0], 1)), t_s)
