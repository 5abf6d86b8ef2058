"""Motion models against textbook formulas re-derived here (Bar-Shalom et al. 2001, 6.2-6.3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ridsafe.gcs.tracking.motion_models import (
    CA_DIM,
    CV_DIM,
    MotionModel,
    convert,
    paper_process_noise,
    transition_matrix,
    white_noise_process_noise,
)

I3 = np.eye(3)
DT = st.floats(0.01, 5.0)


@given(DT)
def test_cv_transition_is_the_paper_block_matrix(dt: float) -> None:
    expected = np.block([[I3, dt * I3], [0 * I3, I3]])
    np.testing.assert_allclose(transition_matrix(2, dt), expected)


@given(DT)
def test_ca_transition_is_the_paper_block_matrix(dt: float) -> None:
    z = 0 * I3
    expected = np.block([[I3, dt * I3, 0.5 * dt**2 * I3], [z, I3, dt * I3], [z, z, I3]])
    np.testing.assert_allclose(transition_matrix(3, dt), expected)


@given(DT, st.floats(0.01, 10.0))
def test_white_acceleration_q(dt: float, q: float) -> None:
    expected = q * np.block([[dt**3 / 3 * I3, dt**2 / 2 * I3], [dt**2 / 2 * I3, dt * I3]])
    np.testing.assert_allclose(white_noise_process_noise(2, q, dt), expected, rtol=1e-12)


@given(DT, st.floats(0.01, 10.0))
def test_white_jerk_q(dt: float, q: float) -> None:
    b = [
        [dt**5 / 20, dt**4 / 8, dt**3 / 6],
        [dt**4 / 8, dt**3 / 3, dt**2 / 2],
        [dt**3 / 6, dt**2 / 2, dt],
    ]
    expected = q * np.block([[v * I3 for v in row] for row in b])
    np.testing.assert_allclose(white_noise_process_noise(3, q, dt), expected, rtol=1e-12)


def test_white_noise_per_axis_density_reaches_only_that_axis() -> None:
    Q = white_noise_process_noise(2, (1.0, 2.0, 0.0), 1.0)
    assert Q[0, 0] == pytest.approx(1 / 3) and Q[1, 1] == pytest.approx(2 / 3)
    assert Q[2, 2] == 0.0 and Q[5, 5] == 0.0 and Q[2, 5] == 0.0


def test_white_noise_discretisation_composes_exactly() -> None:
    """Predicting twice over dt equals once over 2 dt (the point of the exact form)."""
    dt = 0.37
    F, Q = transition_matrix(3, dt), white_noise_process_noise(3, 0.8, dt)
    twice = F @ Q @ F.T + Q
    np.testing.assert_allclose(twice, white_noise_process_noise(3, 0.8, 2 * dt), rtol=1e-12)


def test_paper_q_scales_with_the_real_interval() -> None:
    q = (2.0, 2.0, 2.0, 120.0, 120.0, 120.0)
    np.testing.assert_allclose(paper_process_noise(q, 0.25, 0.25), np.diag(q))
    np.testing.assert_allclose(paper_process_noise(q, 1.0, 0.25), 4.0 * np.diag(q))


def test_model_adds_altitude_diffusion_and_caches() -> None:
    m = MotionModel("CV", 2, q_psd=0.5, q_vertical_psd=0.0, z_diffusion_m2_s=0.5)
    F, Q = m.matrices(2.0)
    assert Q[2, 2] == pytest.approx(1.0)  # 0.5 m^2/s * 2 s, vertical white noise off
    assert Q[0, 0] == pytest.approx(0.5 * 8 / 3)
    assert m.matrices(2.0)[1] is Q
    np.testing.assert_allclose(F, transition_matrix(2, 2.0))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"order": 4, "q_psd": 1.0}, "order"),
        ({"order": 2}, "exactly one"),
        ({"order": 2, "q_psd": 1.0, "q_diag": (1.0,) * 6}, "exactly one"),
        ({"order": 3, "q_diag": (1.0,) * 6}, "needs 9"),
    ],
)
def test_model_validation(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        MotionModel("m", **kwargs)  # type: ignore[arg-type]


@settings(max_examples=30)
@given(st.integers(0, 2), st.integers(0, 10_000))
def test_lift_then_truncate_is_identity(n_extra: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = CV_DIM + n_extra
    x = rng.normal(size=(2, n))
    A = rng.normal(size=(2, n, n))
    P = A @ np.swapaxes(A, 1, 2)
    x9, P9 = convert(x, P, 2, 3, np.array([1.0, 2.0, 3.0]))
    assert x9.shape == (2, CA_DIM + n_extra)
    np.testing.assert_array_equal(x9[:, 6:9], 0.0)
    np.testing.assert_array_equal(
        P9[:, 6:9, 6:9], np.broadcast_to(np.diag([1.0, 2.0, 3.0]), (2, 3, 3))
    )
    np.testing.assert_array_equal(P9[:, 6:9, :6], 0.0)
    np.testing.assert_array_equal(x9[:, 9:], x[:, 6:])  # extra states follow the kinematics
    x6, P6 = convert(x9, P9, 3, 2, 0.0)
    np.testing.assert_array_equal(x6, x)
    np.testing.assert_array_equal(P6, P)


def test_truncate_marginalises_the_acceleration() -> None:
    x = np.arange(10.0)[None]
    P = np.arange(100.0).reshape(1, 10, 10)
    x6, P6 = convert(x, P, 3, 2, 0.0)
    keep = [0, 1, 2, 3, 4, 5, 9]
    np.testing.assert_array_equal(x6[0], x[0, keep])
    np.testing.assert_array_equal(P6[0], P[0][np.ix_(keep, keep)])
