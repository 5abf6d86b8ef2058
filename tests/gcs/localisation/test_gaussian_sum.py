"""The Gaussian sum of RSSI IMMs (started from the grid posterior), and its compiled
bookkeeping against numpy and the containment reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ridsafe.common.ellipsoid import mahalanobis2
from ridsafe.common.pathloss import DB_PER_LN
from ridsafe.gcs.initiation.grid import GridSeed, grid_posterior
from ridsafe.gcs.localisation import mixture_kernels
from ridsafe.gcs.localisation.gaussian_sum import (
    GaussianSumLocaliser,
    _split_along,
    moment_match,
    moment_match_reference,
    reweigh,
)
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracking import imm
from ridsafe.gcs.tracking.imm import Gaussian, ImmState
from tests.gcs.claims import noisy_claim as _claim


def test_huber_split_preserves_the_first_two_moments() -> None:
    rng = np.random.default_rng(0)
    A = rng.normal(size=(10, 10))
    P = A @ A.T + np.eye(10)
    x = rng.normal(size=10)
    state = ImmState((Gaussian(x[None], P[None]),), np.array([[1.0]]), 0.0)
    e = np.array([0.2, -0.4, 0.9])
    e /= np.linalg.norm(e)
    weights = np.array([0.2252246249136750, 0.5495507501726501, 0.2252246249136750])
    parts = [_split_along(state, e, a).modes[0] for a in (-1.0575154134058, 0.0, 1.0575154134058)]
    batch = Gaussian(np.concatenate([g.x for g in parts]), np.concatenate([g.P for g in parts]))
    matched = moment_match(weights, batch)
    np.testing.assert_allclose(matched.x[0], x, atol=1e-9)
    np.testing.assert_allclose(matched.P[0], P, rtol=1e-6, atol=1e-6)
    var_e = e @ P[:3, :3] @ e  # each part is narrower along e
    assert e @ parts[0].P[0, :3, :3] @ e == pytest.approx(
        (1 - 2 * weights[0] * 1.0575154134058**2) * var_e
    )


def test_without_memory_the_weights_are_plain_bayes() -> None:
    prior, loglik = np.array([0.7, 0.2, 0.1]), np.array([-1.0, 0.5, -3.0])
    posterior = prior * np.exp(loglik)
    np.testing.assert_allclose(reweigh(prior, loglik, 1.0, 0.0), posterior / posterior.sum())


def test_weights_the_receptions_cannot_tell_apart_drift_back_together() -> None:
    """Equal likelihoods: the log-ratio fades as exp(-t / memory), so 1e-3 against 0.999
    is 1 : 1 within a few memories; with memory 0 it would stay 1e-3 for ever."""
    w, equal = np.array([0.999, 1e-3]), np.zeros(2)
    ratio0 = math.log(w[0] / w[1])
    for _ in range(5):  # 5 claims, 1 s apart, memory 5 s: the log-ratio times e^-1
        w = reweigh(w, equal, 1.0, 5.0)
    assert math.log(w[0] / w[1]) == pytest.approx(ratio0 * math.exp(-1.0))
    for _ in range(25):
        w = reweigh(w, equal, 1.0, 5.0)
    assert w[1] > 0.4
    np.testing.assert_allclose(reweigh(np.array([0.999, 1e-3]), equal, 30.0, 0.0), [0.999, 1e-3])


def test_a_hypothesis_the_receptions_keep_rejecting_still_goes() -> None:
    """A likelihood ratio of e^-3 per claim, 1 s apart, memory 5 s: the log-ratio settles at
    -3 / (1 - e^-0.2) = -16.5, far under ``prune_weight``."""
    w, loglik = np.array([0.5, 0.5]), np.array([0.0, -3.0])
    for _ in range(60):
        w = reweigh(w, loglik, 1.0, 5.0)
    assert math.log(w[1] / w[0]) == pytest.approx(-3.0 / (1.0 - math.exp(-0.2)), rel=1e-3)
    assert w[1] < PipelineConfig().rssi_filter.prune_weight


def _localiser(seeds: list[GridSeed], t_s: float = 0.0) -> GaussianSumLocaliser:
    return GaussianSumLocaliser(PipelineConfig(), seeds, t_s)


def _seed(z: float, w: float, xy: tuple[float, float] = (0.0, 0.0)) -> GridSeed:
    return GridSeed(w, z, np.array(xy), np.eye(2) * 400.0, 20.0, 1.0)


def test_merge_and_respawn_keep_the_altitude_layers_covered() -> None:
    loc = _localiser([_seed(60.0, 0.5), _seed(60.5, 0.5)])
    fused = loc._merge_close(imm.merge(loc.state, loc.model))
    assert loc.size == 1 and loc.weights[0] == pytest.approx(1.0)
    loc._respawn(fused)
    altitudes = sorted(imm.merge(loc.state, loc.model).x[:, 2])
    assert altitudes == pytest.approx([20.0, 60.25, 100.0], abs=0.5)
    respawned = PipelineConfig().rssi_filter.respawn_weight
    assert sorted(loc.weights)[:2] == pytest.approx([respawned, respawned], rel=0.01)


def test_the_sum_tracks_a_transmitter_and_reports_the_mixture() -> None:
    rng = np.random.default_rng(4)
    rx = np.column_stack((rng.uniform(-500, 500, (12, 2)), rng.uniform(30, 100, 12)))
    p0, v = np.array([-300.0, 0.0, 60.0]), np.array([7.0, 0.0, 0.0])
    claims = [_claim(float(t), p0 + v * t, rx, rng) for t in range(40)]
    loc = _localiser(grid_posterior(claims[:3], (20.0, 60.0, 100.0), 1.0), t_s=2.0)
    for claim in claims[3:]:
        assert loc.update(claim)
        assert loc.size <= PipelineConfig().rssi_filter.max_hypotheses
    fused, mu = loc.predicted(39.0)
    e = p0 + v * 39.0 - fused.x[0, :3]
    assert e @ np.linalg.solve(fused.P[0, :3, :3], e) < 16.3  # chi2_3 at 99.9 %
    assert np.linalg.norm(e[:2]) < 30.0
    assert np.linalg.norm(fused.x[0, 3:6] - v) < 2.0
    assert mu.sum() == pytest.approx(1.0)
    assert loc.weights.sum() == pytest.approx(1.0)


def test_a_failed_update_does_not_shorten_the_weights_memory(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The claim at 1 s is rejected (the IPLF gives up): the state was predicted to 1 s, but
    the weights' memory fades over the 2 s since they last took a likelihood."""
    rng = np.random.default_rng(5)
    rx = np.column_stack((rng.uniform(-500, 500, (12, 2)), rng.uniform(30, 100, 12)))
    p0 = np.array([-300.0, 0.0, 60.0])
    loc = _localiser([_seed(20.0, 0.5, (-300.0, 0.0)), _seed(100.0, 0.5, (-300.0, 0.0))])
    faded_over: list[float] = []

    def recording_reweigh(
        weights: np.ndarray, loglik: np.ndarray, elapsed_s: float, memory_s: float
    ) -> np.ndarray:
        faded_over.append(elapsed_s)
        return reweigh(weights, loglik, elapsed_s, memory_s)

    monkeypatch.setattr("ridsafe.gcs.localisation.gaussian_sum.reweigh", recording_reweigh)
    iplf = loc._iplf
    monkeypatch.setattr(loc, "_iplf", lambda fused, meas: None)
    assert not loc.update(_claim(1.0, p0, rx, rng))
    assert loc.state.t_s == 1.0 and faded_over == []
    monkeypatch.setattr(loc, "_iplf", iplf)
    assert loc.update(_claim(2.0, p0, rx, rng))
    assert loc.update(_claim(2.5, p0, rx, rng))
    assert faded_over == pytest.approx([2.0, 0.5])


def test_mixture_kernels_match_numpy() -> None:
    """The compiled bookkeeping against numpy: moments, split curvature and axis, pairwise
    Mahalanobis distances (inf on and below the diagonal)."""
    rng = np.random.default_rng(12)
    H, n = 5, 7
    A = rng.normal(size=(H, n, n))
    g = Gaussian(rng.normal(0, 100, (H, n)), A @ np.swapaxes(A, 1, 2) + np.eye(n))
    w = rng.uniform(0.1, 1.0, H)
    w /= w.sum()
    got, ref = moment_match(w, g), moment_match_reference(w, g)
    np.testing.assert_allclose(got.x, ref.x, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got.P, ref.P, rtol=1e-12, atol=1e-9)
    rx = rng.normal(0, 300, (9, 3))
    curvature, axis = mixture_kernels.split_curvature(g.x, g.P, rx)
    lam, vec = np.linalg.eigh(g.P[:, :3, :3])
    d2 = np.min(np.sum((g.x[:, None, :3] - rx[None]) ** 2, axis=2), axis=1)
    np.testing.assert_allclose(curvature, 0.5 * DB_PER_LN * lam[:, -1] / np.maximum(d2, 1.0))
    np.testing.assert_allclose(np.abs(np.einsum("hi,hi->h", axis, vec[:, :, -1])), 1.0)
    m2 = mixture_kernels.pair_mahalanobis2(g.x[:, :3].copy(), g.P[:, :3, :3].copy())
    for a in range(H):
        for b in range(H):
            if b <= a:
                assert m2[a, b] == np.inf
                continue
            d = g.x[a, :3] - g.x[b, :3]
            assert m2[a, b] == pytest.approx(
                float(mahalanobis2(d, g.P[a, :3, :3] + g.P[b, :3, :3]))
            )


def test_a_power_shift_moves_every_hypothesis_power_and_nothing_else() -> None:
    loc = _localiser([_seed(20.0, 0.5), _seed(100.0, 0.5, (50.0, 0.0))])
    before, mu_before = loc.predicted(1.0)
    loc.shift_power(-3.5)
    after, mu_after = loc.predicted(1.0)
    assert after.x[0, -1] == pytest.approx(before.x[0, -1] - 3.5)
    np.testing.assert_allclose(after.x[0, :-1], before.x[0, :-1])
    np.testing.assert_allclose(after.P, before.P)
    np.testing.assert_allclose(mu_after, mu_before)
    for mode in loc.state.modes:
        np.testing.assert_allclose(mode.x[:, -1], 20.0 - 3.5)
