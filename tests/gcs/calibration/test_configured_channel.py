"""``calibration.enabled: auto``: the configured channel is kept while the cooperative
receptions fit it, and replaced by the fitted one as soon as they do not."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.common.config import from_mapping
from ridsafe.common.errors import ConfigError
from ridsafe.gcs.calibration.channel_fit import check_configured_channel
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import LabelledReceptions
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly
from ridsafe.gcs.pipeline_config import PipelineConfig
from tests.gcs.claims import free_space_claim

ALPHA = 1e-3


def _receptions(
    seed: int, sigma_db: float, exponent: float = 2.0, bias_std_db: float = 0.0, k: int = 600
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``k`` receptions among 12 aircraft 30-900 m apart, levels drawn per transmitter."""
    rng = np.random.default_rng(seed)
    level = rng.normal(-20.0, 1.5, 12)
    bias = rng.normal(0.0, bias_std_db, 12)
    tx = rng.integers(1, 13, k)
    rx = (tx + rng.integers(1, 12, k) - 1) % 12 + 1
    d = rng.uniform(30.0, 900.0, k)
    noise = rng.normal(0.0, sigma_db, k)
    rssi = level[tx - 1] + bias[rx - 1] - 10.0 * exponent * np.log10(d) + noise
    return tx, d, rssi


def test_the_configured_channel_fits_its_own_receptions() -> None:
    """Free space with the configured 1 dB: accepted in 50 of 50 draws at alpha 1e-3, and
    a quieter channel than configured is accepted too (the configured one is conservative)."""
    for seed in range(50):
        tx, d, rssi = _receptions(seed, 1.0)
        check = check_configured_channel(tx, d, rssi, 1.0, 0.0, ALPHA)
        assert check.fits, (seed, check.describe())
        assert check.residual_std_db == pytest.approx(1.0, abs=0.1)
    tx, d, rssi = _receptions(99, 0.5)
    assert check_configured_channel(tx, d, rssi, 1.0, 0.0, ALPHA).fits


@pytest.mark.parametrize(
    ("what", "sigma_db", "exponent", "bias_std_db"),
    [
        ("30 % more noise", 1.3, 2.0, 0.0),
        ("exponent 2.3", 1.0, 2.3, 0.0),
        ("receiver biases of 1 dB", 1.0, 2.0, 1.0),
    ],
)
def test_a_channel_unlike_the_configured_one_is_rejected(
    what: str, sigma_db: float, exponent: float, bias_std_db: float
) -> None:
    """600 receptions (what 16 aircraft collect in about 3 s) are enough."""
    for seed in range(10):
        tx, d, rssi = _receptions(seed, sigma_db, exponent, bias_std_db)
        check = check_configured_channel(tx, d, rssi, 1.0, 0.0, ALPHA)
        assert not check.fits, (what, seed, check.describe())


def test_the_position_term_keeps_close_pairs_honest() -> None:
    """Receptions 10-40 m apart with 2 m position errors at both ends: on the model with the
    detectors' position term they fit; without it the same receptions are rejected."""
    rng = np.random.default_rng(3)
    k = 2000
    tx = rng.integers(1, 9, k)
    d_true = rng.uniform(10.0, 40.0, k)
    d_seen = np.abs(d_true + rng.normal(0.0, 2.0, k))
    rssi = -20.0 - 20.0 * np.log10(d_true) + rng.normal(0.0, 1.0, k)
    assert check_configured_channel(tx, d_seen, rssi, 1.0, 2.0, ALPHA).fits
    assert not check_configured_channel(tx, d_seen, rssi, 1.0, 0.0, ALPHA).fits


AUTO = CalibrationConfig(enabled="auto", min_samples=50, min_time_s=0.0, refit_s=5.0)
POSITIONS = {i: [120.0 * i - 300.0, 80.0 * (i % 3) - 80.0, 40.0 + 5.0 * i] for i in range(1, 7)}


def _fleet_claims(t_s: float, rx_bias_db: dict[int, float]) -> list[ObservedClaim]:
    """Every aircraft of ``POSITIONS`` heard by the others, noise-free free space plus each
    receiver's bias."""
    claims = []
    for i, p in POSITIONS.items():
        others = {j: q for j, q in POSITIONS.items() if j != i}
        claim = free_space_claim(f"RID{i}", t_s, p, others)
        bias = np.array([rx_bias_db.get(int(s), 0.0) for s in claim.rx_sysid])
        claims.append(dataclasses.replace(claim, rssi_dbm=readonly(claim.rssi_dbm + bias)))
    return claims


def _fly(
    pipeline: CalibratingPipeline, t_from_s: float, t_to_s: float, bias: dict[int, float]
) -> None:
    t = t_from_s
    while t < t_to_s:
        pipeline.step(t + 0.25, _fleet_claims(t, bias))
        t += 1.0


def _channel(pipeline: CalibratingPipeline) -> str:
    if pipeline.inner is None:
        return "warming up"
    return "configured" if pipeline.on_configured_channel else "fitted"


def test_auto_keeps_the_configured_channel_while_it_fits_and_switches_when_it_stops() -> None:
    """On the configured channel the inner pipeline gets the configured noise std and the
    RSSI unmapped; once receivers develop 4 dB biases the next check fits the channel."""
    pipeline = CalibratingPipeline(PipelineConfig(calibration=AUTO))
    _fly(pipeline, 0.0, 12.0, {})
    assert _channel(pipeline) == "configured"
    assert pipeline.inner is not None and pipeline.inner.config.rssi_sigma_db == 1.0
    biases = {1: 4.0, 2: -4.0, 3: 4.0, 4: -4.0, 5: 4.0, 6: -4.0}
    _fly(pipeline, 12.0, 60.0, biases)
    assert _channel(pipeline) == "fitted"
    estimate = pipeline.estimate
    assert estimate is not None
    fitted = [estimate.rx_bias_db[i] - estimate.rx_bias_db[2] for i in (1, 3)]
    assert all(b > 2.0 for b in fitted)


def test_auto_fits_at_once_when_the_warm_up_rejects_the_configured_channel() -> None:
    pipeline = CalibratingPipeline(PipelineConfig(calibration=AUTO))
    _fly(pipeline, 0.0, 12.0, {1: 5.0, 2: -5.0, 3: 3.0, 4: -3.0})
    assert _channel(pipeline) == "fitted" and pipeline.estimate is not None


def test_auto_is_accepted_from_yaml_and_a_bad_alpha_is_an_error() -> None:
    cfg = from_mapping(CalibrationConfig, {"enabled": "auto"}, "x.yaml")
    assert cfg.enabled == "auto"
    with pytest.raises(ConfigError, match="enabled"):
        from_mapping(CalibrationConfig, {"enabled": "sometimes"}, "x.yaml")
    with pytest.raises(ConfigError, match="configured_alpha"):
        from_mapping(CalibrationConfig, {"enabled": "auto", "configured_alpha": 0.0}, "x.yaml")


def test_the_labelled_receptions_keep_the_newest_when_full() -> None:
    """A ring of 5: after 3 + 4 + 2 receptions the 5 newest remain, whatever their order."""
    ring = LabelledReceptions(5)
    newest: list[float] = []
    for tx, k in ((1, 3), (2, 4), (3, 2)):
        rssi = np.arange(k, dtype=np.float64) + 10.0 * tx
        ring.add(tx, np.arange(k, dtype=np.int64), rssi + 1000.0, rssi)
        newest = (newest + rssi.tolist())[-5:]
    assert len(ring) == 5
    assert sorted(ring.rssi_dbm.tolist()) == sorted(newest)
    np.testing.assert_array_equal(ring.distance_m - ring.rssi_dbm, 1000.0)
    assert sorted(ring.tx_sysid.tolist()) == [2, 2, 2, 3, 3]
