"""Region publishing (``gcs/region/publishing.py``): off = the estimate itself; on = the
authors' clamp, step limit, growth limit and moving averages, each re-derived by hand."""

from __future__ import annotations

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.gcs.pipeline_config import RegionPublishConfig
from ridsafe.gcs.region.publishing import Published, RegionPublisher, clamp_std, publish_step

ON = RegionPublishConfig(enabled=True)


def test_off_publishes_the_estimate_itself() -> None:
    publisher = RegionPublisher(RegionPublishConfig())
    c, P = np.array([1.0, 2.0, 3.0]), np.diag([1e6, 1.0, 0.01])
    center, cov = publisher.publish("X", c, P)
    assert center is c and cov is P


def test_clamp_keeps_eigenvectors_and_clips_stds() -> None:
    R = np.linalg.qr(np.array([[1.0, 2.0, 0.5], [0.3, -1.0, 2.0], [1.5, 0.2, -0.7]]))[0]
    P = R @ np.diag([1e4, 100.0, 1.0]) @ R.T
    out = clamp_std(P, 4.0, 35.0)
    lam, V = np.linalg.eigh(out)
    np.testing.assert_allclose(lam, [16.0, 100.0, 1225.0], rtol=1e-9)
    # Same principal directions (up to sign) as the input.
    _lam_in, V_in = np.linalg.eigh(P)
    np.testing.assert_allclose(np.abs(V.T @ V_in), np.eye(3), atol=1e-9)


def test_first_region_is_the_clamped_estimate() -> None:
    out = publish_step(None, np.array([10.0, 0.0, 50.0]), np.diag([1e5, 9.0, 1.0]), ON)
    np.testing.assert_allclose(out.center_enu_m, [10.0, 0.0, 50.0])
    np.testing.assert_allclose(np.diag(out.cov_enu_m2), [1225.0, 16.0, 16.0])


def test_step_limit_then_moving_average_on_the_centre() -> None:
    previous = Published(np.zeros(3), np.eye(3) * 100.0)
    out = publish_step(previous, np.array([300.0, 400.0, 0.0]), np.eye(3) * 100.0, ON)
    # 500 m away: limited to 30 m along the way, then 35 % of that.
    np.testing.assert_allclose(out.center_enu_m, 0.35 * 30.0 * np.array([0.6, 0.8, 0.0]))
    np.testing.assert_allclose(out.cov_enu_m2, np.eye(3) * 100.0)


def test_trace_growth_limit_then_moving_average_on_the_covariance() -> None:
    previous = Published(np.zeros(3), np.eye(3) * 100.0)
    out = publish_step(previous, np.zeros(3), np.eye(3) * 1000.0, ON)
    # 1000 > 1.8 * 100 per axis: scaled to 180, then 25 % of the way from 100.
    np.testing.assert_allclose(out.cov_enu_m2, np.eye(3) * (0.75 * 100.0 + 0.25 * 180.0))


def test_limits_can_be_switched_off() -> None:
    cfg = RegionPublishConfig(
        enabled=True,
        max_center_step_m=0.0,
        max_trace_growth=0.0,
        center_ema_gain=1.0,
        cov_ema_gain=1.0,
        std_max_m=1e6,
    )
    previous = Published(np.zeros(3), np.eye(3) * 100.0)
    out = publish_step(previous, np.array([300.0, 400.0, 0.0]), np.eye(3) * 1e4, cfg)
    np.testing.assert_allclose(out.center_enu_m, [300.0, 400.0, 0.0])
    np.testing.assert_allclose(out.cov_enu_m2, np.eye(3) * 1e4)


def test_region_stays_bounded_and_positive_definite_under_wild_estimates() -> None:
    rng = np.random.default_rng(3)
    publisher = RegionPublisher(ON)
    for _ in range(400):
        A = rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-3, 4)
        center, cov = publisher.publish("X", rng.normal(size=3) * 1e3, A @ A.T)
        lam = np.linalg.eigvalsh(cov)
        assert lam[0] >= 16.0 * (1 - 1e-9) and lam[-1] <= 1225.0 * (1 + 1e-9)
        assert np.all(np.isfinite(center))


def test_forget_restarts_from_the_estimate() -> None:
    publisher = RegionPublisher(ON)
    publisher.publish("X", np.zeros(3), np.eye(3) * 100.0)
    publisher.forget("X")
    center, _cov = publisher.publish("X", np.array([500.0, 0.0, 0.0]), np.eye(3) * 100.0)
    np.testing.assert_allclose(center, [500.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("field", "value"),
    [("std_min_m", 0.0), ("std_max_m", 1.0), ("center_ema_gain", 0.0), ("max_trace_growth", 0.5)],
)
def test_bad_values_are_rejected_by_name(field: str, value: float) -> None:
    with pytest.raises(FieldValueError, match=field):
        RegionPublishConfig(**{field: value})  # type: ignore[arg-type]
