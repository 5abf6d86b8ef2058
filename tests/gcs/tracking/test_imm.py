"""The IMM: its transition convention (asymmetric matrix), textbook formulas re-derived, a
differential test against filterpy where the state sizes agree, numerical health and a seeded
NEES consistency test."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter
from scipy import stats

from ridsafe.gcs.tracking import imm
from ridsafe.gcs.tracking.imm import Gaussian, ImmModel, ImmState, ModeUpdate
from ridsafe.gcs.tracking.motion_models import MotionModel, convert, transition_matrix

ASYMMETRIC = np.array([[0.9, 0.1], [0.3, 0.7]])
H_POS9 = np.hstack((np.eye(3), np.zeros((3, 6))))


def _fix_updater(z: np.ndarray, R: np.ndarray) -> Callable[[int, Gaussian], ModeUpdate]:
    """Every mode updated with the position fix z (H = [I3 0])."""

    def updater(j: int, g: Gaussian) -> ModeUpdate:
        return imm.kalman_update(g, z, H_POS9[:, : g.x.shape[1]], R)[0]

    return updater


def _model(transition: np.ndarray, cv_q: float = 0.5, ca_q: float = 0.2) -> ImmModel:
    return ImmModel(
        models=(MotionModel("CV", 2, q_psd=cv_q), MotionModel("CA", 3, q_psd=ca_q)),
        transition=transition,
        dt_ref_s=0.25,
        lift_accel_var=4.0,
    )


def _state(mu: list[float], t_s: float = 0.0) -> ImmState:
    x6, P6 = np.zeros((1, 6)), np.eye(6)[None] * 10.0
    x9, P9 = np.zeros((1, 9)), np.eye(9)[None] * 10.0
    x9[0, 6] = 1.0  # the CA mode believes in an acceleration
    return ImmState((Gaussian(x6, P6), Gaussian(x9, P9)), np.array([mu]), t_s)


@pytest.mark.parametrize(("mu", "expected"), [([1.0, 0.0], [0.9, 0.1]), ([0.0, 1.0], [0.3, 0.7])])
def test_transition_rows_are_the_from_mode(mu: list[float], expected: list[float]) -> None:
    """transition[i, j] = P(j at k | i at k-1): all mass in mode i moves by row i."""
    out = imm.predict(_state(mu), _model(ASYMMETRIC), 0.25)
    np.testing.assert_allclose(out.mu[0], expected)


def test_transition_over_real_intervals_composes() -> None:
    half = imm.transition_over(ASYMMETRIC, 0.125, 0.25)
    np.testing.assert_allclose(half @ half, ASYMMETRIC, atol=1e-12)
    np.testing.assert_allclose(half.sum(axis=1), 1.0)
    np.testing.assert_allclose(
        imm.transition_over(ASYMMETRIC, 0.75, 0.25), np.linalg.matrix_power(ASYMMETRIC, 3)
    )
    np.testing.assert_array_equal(imm.transition_over(ASYMMETRIC, 0.0, 0.25), np.eye(2))


def test_mixing_across_sizes_lifts_and_truncates() -> None:
    """All probability in CV and a chain that always moves to CA: CA starts from the lifted
    CV estimate. All in CA and a chain that always moves to CV: CV starts from the truncated
    CA estimate."""
    to_ca = np.array([[0.0, 1.0], [0.0, 1.0]])
    state = _state([1.0, 0.0])
    mixed, c = imm.mix(state, _model(to_ca), to_ca)
    lifted = convert(state.modes[0].x, state.modes[0].P, 2, 3, 4.0)
    np.testing.assert_allclose(mixed[1].x, lifted[0])
    np.testing.assert_allclose(mixed[1].P, lifted[1])
    np.testing.assert_allclose(c[0], [0.0, 1.0], atol=1e-12)
    to_cv = np.array([[1.0, 0.0], [1.0, 0.0]])
    state = _state([0.0, 1.0])
    mixed, _ = imm.mix(state, _model(to_cv), to_cv)
    np.testing.assert_allclose(mixed[0].x, state.modes[1].x[:, :6])
    np.testing.assert_allclose(mixed[0].P, state.modes[1].P[:, :6, :6])


def test_mixing_adds_the_spread_of_the_means() -> None:
    """P0_j = sum_i w_ij (P_i + (x_i - x0_j)(x_i - x0_j)^T), re-derived by hand."""
    model = _model(ASYMMETRIC)
    state = _state([0.4, 0.6])
    mixed, c = imm.mix(state, model, ASYMMETRIC)
    mu = np.array([0.4, 0.6])
    cbar = mu @ ASYMMETRIC
    w = ASYMMETRIC * mu[:, None] / cbar[None, :]
    conv = [convert(g.x[0], g.P[0], o, 3, 4.0) for g, o in zip(state.modes, (2, 3), strict=True)]
    x0 = w[0, 1] * conv[0][0] + w[1, 1] * conv[1][0]
    P0 = sum(w[i, 1] * (conv[i][1] + np.outer(conv[i][0] - x0, conv[i][0] - x0)) for i in range(2))
    np.testing.assert_allclose(mixed[1].x[0], x0)
    np.testing.assert_allclose(mixed[1].P[0], P0)
    np.testing.assert_allclose(c[0], cbar)


def test_merge_is_the_papers_equation() -> None:
    state = _state([0.3, 0.7])
    g = imm.merge(state, _model(ASYMMETRIC), order=2)
    x_cv, x_ca = state.modes[0].x[0], state.modes[1].x[0, :6]
    x = 0.3 * x_cv + 0.7 * x_ca
    P = 0.3 * (state.modes[0].P[0] + np.outer(x_cv - x, x_cv - x)) + 0.7 * (
        state.modes[1].P[0][:6, :6] + np.outer(x_ca - x, x_ca - x)
    )
    np.testing.assert_allclose(g.x[0], x)
    np.testing.assert_allclose(g.P[0], P)


def test_kalman_update_is_the_textbook_one() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    P = A @ A.T + np.eye(6)
    x = rng.normal(size=6)
    H = np.hstack((np.eye(3), np.zeros((3, 3))))
    R = np.diag([4.0, 9.0, 25.0])
    z = rng.normal(size=3)
    upd, nis = imm.kalman_update(Gaussian(x[None], P[None]), z, H, R)
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    nu = z - H @ x
    np.testing.assert_allclose(upd.x[0], x + K @ nu)
    np.testing.assert_allclose(upd.P[0], (np.eye(6) - K @ H) @ P, atol=1e-10)
    assert nis[0] == pytest.approx(nu @ np.linalg.solve(S, nu))
    assert upd.log_likelihood[0] == pytest.approx(
        stats.multivariate_normal(np.zeros(3), S).logpdf(nu)
    )


def _filterpy_kf(F: np.ndarray, Q: np.ndarray, R: np.ndarray, P0: np.ndarray) -> KalmanFilter:
    kf = KalmanFilter(dim_x=9, dim_z=3)
    kf.F, kf.Q, kf.H, kf.R, kf.P = F, Q, H_POS9, R, P0.copy()
    kf.x = np.zeros((9, 1))
    return kf


def test_matches_filterpy_when_both_modes_have_nine_states() -> None:
    """filterpy's IMMEstimator needs equal sizes: two CA-order modes of different noise."""
    dt, R = 0.25, np.diag([30.0, 30.0, 60.0])
    models = (MotionModel("quiet", 3, q_psd=0.1), MotionModel("agile", 3, q_psd=5.0))
    model = ImmModel(models, ASYMMETRIC, dt, 0.0)
    P0 = np.eye(9) * 50.0
    mu0 = np.array([0.45, 0.55])
    fp = IMMEstimator([_filterpy_kf(*m.matrices(dt), R, P0) for m in models], mu0, ASYMMETRIC)
    state = ImmState(
        tuple(Gaussian(np.zeros((1, 9)), P0[None].copy()) for _ in models), mu0[None], 0.0
    )
    rng = np.random.default_rng(11)
    for k in range(1, 40):
        z = np.array([3.0 * k * dt, -k * dt, 0.5 * (k * dt) ** 2]) + rng.normal(0, 5, 3)
        fp.predict()
        fp.update(z[:, None])
        state = imm.predict(state, model, k * dt)
        out = imm.update(state, _fix_updater(z, R))
        assert out is not None
        state = out[0]
        fused = imm.merge(state, model, order=3)
        np.testing.assert_allclose(state.mu[0], fp.mu, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(fused.x[0], fp.x[:, 0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(fused.P[0], fp.P, rtol=1e-9, atol=1e-9)


def test_covariance_stays_symmetric_positive_definite_when_badly_conditioned() -> None:
    """Fixes accurate to a millimetre in one axis and a kilometre in another, for minutes."""
    model = _model(np.array([[0.98, 0.02], [0.16, 0.84]]))
    state = _state([0.45, 0.55])
    R = np.diag([1e-6, 1e6, 1.0])
    rng = np.random.default_rng(5)
    for k in range(1, 600):
        state = imm.predict(state, model, 0.25 * k)
        z = rng.normal(0.0, np.sqrt(np.diag(R)))
        out = imm.update(state, _fix_updater(z, R))
        assert out is not None
        state = out[0]
    for g in state.modes:
        np.testing.assert_array_equal(g.P, np.swapaxes(g.P, 1, 2))
        assert np.linalg.eigvalsh(g.P[0]).min() > 0.0
    assert np.all(np.isfinite(state.mu)) and state.mu.sum() == pytest.approx(1.0)


def test_nees_is_chi_square_consistent_on_a_known_trajectory() -> None:
    """Seeded Monte-Carlo: truth from the CV model's own white acceleration, position fixes
    with known R; the NEES of the fused position averaged over runs stays inside its
    chi-square 99.9 % bounds at every checked step."""
    q, dt, R = 0.5, 1.0, np.diag([100.0, 100.0, 400.0])
    model = _model(np.array([[0.98, 0.02], [0.16, 0.84]]), cv_q=q, ca_q=0.01)
    F, Q = MotionModel("CV", 2, q_psd=q).matrices(dt)
    runs, steps = 60, 40
    rng = np.random.default_rng(2024)
    nees = np.zeros((runs, steps))
    for r in range(runs):
        truth = np.r_[rng.normal(0, 30, 3), rng.normal(0, 3, 3)]
        x0 = truth + rng.normal(0, [30, 30, 30, 3, 3, 3])
        P0 = np.diag([900.0] * 3 + [9.0] * 3)
        x9, P9 = convert(x0[None], P0[None], 2, 3, 0.01)
        state = ImmState(
            (Gaussian(x0[None], P0[None]), Gaussian(x9, P9)), np.array([[0.45, 0.55]]), 0.0
        )
        for k in range(steps):
            truth = F @ truth + rng.multivariate_normal(np.zeros(6), Q)
            z = truth[:3] + rng.multivariate_normal(np.zeros(3), R)
            state = imm.predict(state, model, (k + 1) * dt)
            out = imm.update(state, _fix_updater(z, R))
            assert out is not None
            state = out[0]
            fused = imm.merge(state, model)
            e = truth[:3] - fused.x[0, :3]
            nees[r, k] = e @ np.linalg.solve(fused.P[0, :3, :3], e)
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 3 * runs) / runs
    mean = nees.mean(axis=0)
    assert np.all((mean[5:] > lo) & (mean[5:] < hi)), (lo, hi, mean)


def test_transition_matrix_helper_agrees() -> None:
    np.testing.assert_allclose(_model(ASYMMETRIC).matrices(1, 0.5)[0], transition_matrix(3, 0.5))


def _random_state(rng: np.random.Generator, model: ImmModel, H: int, t_s: float) -> ImmState:
    modes = []
    for j in range(len(model.models)):
        n = model.dim(j)
        A = rng.normal(size=(H, n, n))
        modes.append(Gaussian(rng.normal(0, 50, (H, n)), A @ np.swapaxes(A, 1, 2) + np.eye(n)))
    mu = rng.uniform(0.05, 1.0, (H, len(model.models)))
    return ImmState(tuple(modes), mu / mu.sum(axis=1, keepdims=True), t_s)


@pytest.mark.parametrize("dt", [0.25, 0.6, 3.0])
def test_compiled_predict_and_merge_match_the_numpy_reference(dt: float) -> None:
    """A batch of 4 with a trailing extra state, per-axis lift variances, an asymmetric chain
    over fractional and whole multiples of dt_ref."""
    model = ImmModel(
        models=(MotionModel("CV", 2, q_psd=0.5), MotionModel("CA", 3, q_psd=0.2)),
        transition=ASYMMETRIC,
        dt_ref_s=0.25,
        lift_accel_var=np.array([4.0, 5.0, 0.5]),
        n_extra=1,
        extra_q=np.array([0.3]),
    )
    state = _random_state(np.random.default_rng(4), model, 4, 1.0)
    got, ref = imm.predict(state, model, 1.0 + dt), imm.predict_reference(state, model, 1.0 + dt)
    np.testing.assert_allclose(got.mu, ref.mu, rtol=1e-12)
    for g, r in zip(got.modes, ref.modes, strict=True):
        np.testing.assert_allclose(g.x, r.x, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(g.P, r.P, rtol=1e-10, atol=1e-9)
        np.testing.assert_array_equal(g.P, np.swapaxes(g.P, 1, 2))
    for order in (2, 3):
        fused, fused_ref = imm.merge(got, model, order), imm.merge_reference(got, model, order)
        np.testing.assert_allclose(fused.x, fused_ref.x, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(fused.P, fused_ref.P, rtol=1e-10, atol=1e-9)


def test_a_cached_interval_is_the_same_whatever_came_before_it() -> None:
    """The caches key an interval rounded to 1e-9 s. Two intervals that round alike must get
    the same matrices however the cache was filled: a model lives across the runs of a sweep
    worker, and its outputs may not depend on which run came first."""
    dt, near = 0.3, 0.3 + 4e-11  # the same key, different floats
    imm._TRANSITION_CACHE.clear()
    fresh = imm.transition_over(ASYMMETRIC, dt, 0.25).copy()
    imm._TRANSITION_CACHE.clear()
    imm.transition_over(ASYMMETRIC, near, 0.25)
    np.testing.assert_array_equal(imm.transition_over(ASYMMETRIC, dt, 0.25), fresh)

    fresh_model, used_model = _model(ASYMMETRIC), _model(ASYMMETRIC)
    used_model.over(near)
    (pi, fs, qs), (pi0, fs0, qs0) = used_model.over(dt), fresh_model.over(dt)
    for got, want in zip((pi, *fs, *qs), (pi0, *fs0, *qs0), strict=True):
        np.testing.assert_array_equal(got, want)
    fresh_cv, used_cv = MotionModel("CV", 2, q_psd=0.5), MotionModel("CV", 2, q_psd=0.5)
    used_cv.matrices(near)
    for got, want in zip(used_cv.matrices(dt), fresh_cv.matrices(dt), strict=True):
        np.testing.assert_array_equal(got, want)
