"""The authors' NLLS -> IMM (``authors_imm``) and their fix covariance: textbook formulas
re-derived, the bounds they promise, and a seeded synthetic run that localises."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ridsafe.gcs.localisation.authors_fix_covariance import authors_fix_covariance, eigclip
from ridsafe.gcs.localisation.authors_imm import AuthorsImm
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic

RX = np.array(
    [
        [0.0, 0.0, 40.0],
        [500.0, 0.0, 90.0],
        [0.0, 500.0, 60.0],
        [500.0, 500.0, 30.0],
        [250.0, 250, 110],
    ]
)
P_TRUE = np.array([180.0, 320.0, 70.0])


def test_fix_covariance_is_gauss_newton_when_residuals_are_small_and_geometry_good() -> None:
    # Residuals of 0.5 dB alternating: s^2 = 5 * 0.25 / 2, the mismatch term std(e) = 0.5.
    e = np.array([0.5, -0.5, 0.5, -0.5, 0.5])
    C = authors_fix_covariance(RX, P_TRUE, e)
    lam = np.linalg.eigvalsh(C)
    assert lam[0] >= 2.25 - 1e-9 and lam[-1] <= 2500.0 + 1e-9
    # Worse residuals never shrink it.
    C_worse = authors_fix_covariance(RX, P_TRUE, 4.0 * e)
    assert np.all(np.linalg.eigvalsh(C_worse - C) >= -1e-9)


def test_fix_covariance_is_bounded_for_collinear_receivers() -> None:
    line = np.array([[0.0, 0.0, 50.0], [100.0, 0.0, 50.0], [200.0, 0.0, 50.0], [300.0, 0.0, 50.0]])
    C = authors_fix_covariance(
        line, np.array([150.0, 400.0, 60.0]), np.array([3.0, -2.0, 1.0, 0.0])
    )
    lam = np.linalg.eigvalsh(C)
    np.testing.assert_allclose(lam[-1], 2500.0)
    assert lam[0] >= 2.25 - 1e-9


def test_eigclip_clips_eigenvalues() -> None:
    np.testing.assert_allclose(
        eigclip(np.diag([0.1, 50.0, 1e5]), 1.0, 100.0), np.diag([1.0, 50.0, 100.0])
    )


def _filter() -> AuthorsImm:
    return AuthorsImm(PipelineConfig(), np.zeros(3), 0.0, 20.0)


def test_one_update_is_the_textbook_kalman_update_per_mode() -> None:
    f = _filter()
    P_cv, x_cv = f.P[0].copy(), f.x[0].copy()
    z, R = np.array([3.0, -2.0, 1.0]), np.diag([30.0, 40.0, 50.0])
    assert f.measure(z, R)
    H = np.hstack((np.eye(3), np.zeros((3, 3))))
    S = H @ P_cv @ H.T + R
    K = P_cv @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(f.x[0], x_cv + K @ (z - H @ x_cv), atol=1e-9)
    P_post = (np.eye(6) - K @ H) @ P_cv
    np.testing.assert_allclose(f.P[0][3:, 3:], P_post[3:, 3:], atol=1e-6)


def test_modes_do_not_mix_and_probabilities_move_by_likelihood_only() -> None:
    f = _filter()
    f.x[1][3:6] = [5.0, 0.0, 0.0]  # the CA mode believes in a velocity, CV does not
    mu0 = f.mu.copy()
    f.predicted(1.0)  # four ticks, no measurement
    np.testing.assert_allclose(f.mu, mu0)  # no Markov step through the transition matrix
    np.testing.assert_allclose(f.x[0][:3], 0.0)  # no mixing: CV did not take CA's velocity
    np.testing.assert_allclose(f.x[1][:3], [5.0, 0.0, 0.0])


def test_a_far_fix_is_rejected_and_a_moderate_one_downweighted() -> None:
    f = _filter()
    f.P = [np.eye(6) * 4.0, np.eye(9) * 4.0]
    R = np.eye(3) * 4.0
    assert not f.measure(np.array([200.0, 0.0, 0.0]), R)  # NIS 5000 > 60
    assert f.measure(np.array([12.0, 0.0, 0.0]), R)  # NIS 18: R scaled by 18 / 11.34
    # Gain with the scaled R: 4 / (4 + 4 * 18 / 11.34).
    np.testing.assert_allclose(f.x[0][0], 12.0 * 4.0 / (4.0 + 4.0 * 18.0 / 11.34), rtol=1e-6)


def test_predicted_is_idempotent_on_the_tick_grid() -> None:
    f = _filter()
    f.x[0][3:6] = [2.0, 0.0, 0.0]
    a, _ = f.predicted(1.1)
    b, _ = f.predicted(1.1)
    np.testing.assert_allclose(a.x, b.x)
    assert f.t_tick_s == pytest.approx(1.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_synthetic_run_localises(seed: int) -> None:
    scene = Scene(seed=seed, n_receivers=8, duration_s=60.0)
    cfg = PipelineConfig(
        estimator="authors_imm",
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=5.0),
    )
    m = run_pipeline(make_traffic(scene), cfg)
    assert m.errors_m, "no estimate"
    rmse = math.sqrt(float(np.mean(np.square(m.errors_m))))
    assert rmse < 150.0
