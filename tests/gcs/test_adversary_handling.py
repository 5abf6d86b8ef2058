"""What the GCS assumes beyond the paper's spoofer: a power that changes every message
(``rssi_filter.tx_power_jitter: adaptive``) and a spoofer that falls silent
(``tracks.coast_max_radius_m``).

Oracles: the per-message power variance a known offset sequence has; the synthetic scene's true
spoofer path (``gcs/synthetic/traffic.py``) for the track error; the region's semi-axes, which
grow with the prediction's covariance while nothing is heard.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.initiation.grid import grid_posterior
from ridsafe.gcs.localisation.config import RssiFilterConfig
from ridsafe.gcs.localisation.power_jitter import PowerJitter
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly
from ridsafe.gcs.pipeline_config import ForcedAlertConfig, PipelineConfig, TrackConfig
from ridsafe.gcs.synthetic.traffic import CYCLE_S, SPOOFER_ID, Scene, Traffic, make_traffic
from tests.gcs.claims import observed_claim

RX = np.array(
    [[0.0, 0.0, 50.0], [400.0, 0.0, 60.0], [0.0, 400.0, 40.0], [400.0, 400.0, 70.0],
     [200.0, -150.0, 55.0], [-150.0, 200.0, 65.0]]
)  # fmt: skip
P_TRUE = np.array([150.0, 250.0, 60.0])


def test_the_jitter_estimate_finds_a_per_message_power_and_none_in_a_constant_one() -> None:
    rng = np.random.default_rng(4)
    u, C = np.array([*P_TRUE, 20.0]), np.diag([1.0, 1.0, 1.0, 0.01])
    clean = received_power_dbm(20.0, np.linalg.norm(RX - P_TRUE, axis=1))
    jittery = PowerJitter(forgetting=0.02, threshold_db=2.0)
    steady = PowerJitter(forgetting=0.02, threshold_db=2.0)
    for _ in range(400):
        noise = rng.normal(0.0, 1.0, RX.shape[0])
        jittery.observe(u, C, RX, clean + rng.normal(0.0, 6.0) + noise, 1.0)
        steady.observe(u, C, RX, clean + noise, 1.0)
    assert jittery.variance_db2 == pytest.approx(36.0, rel=0.3)
    assert steady.variance_db2 == 0.0


def _claim(t: float, rx: np.ndarray, rssi: np.ndarray) -> ObservedClaim:
    return observed_claim("x", t, P_TRUE, rx, rssi)


def test_the_track_start_profiles_one_power_per_message() -> None:
    """Receivers moving between messages (with one set, a per-message power only adds a
    constant to the pooled cost); the powers are 8 dB apart on average."""
    errors: dict[bool, list[float]] = {True: [], False: []}
    for seed in range(10):
        rng = np.random.default_rng(seed)
        claims = []
        for t in (0.0, 1.0, 2.0):
            rx = RX + t * np.array([60.0, -45.0, 0.0]) * np.array([[1], [-1], [1], [-1], [1], [-1]])
            clean = received_power_dbm(20.0, np.linalg.norm(rx - P_TRUE, axis=1))
            claims.append(_claim(t, rx, clean + rng.normal(0.0, 8.0) + rng.normal(0.0, 1.0, 6)))
        for per_message in (True, False):
            seeds = grid_posterior(claims, (60.0,), 1.0, per_message_power=per_message)
            w = np.array([s.weight for s in seeds])
            mean = w @ np.array([s.p_xy_m for s in seeds])
            errors[per_message].append(float(np.linalg.norm(mean - P_TRUE[:2])))
    assert np.median(errors[True]) < 15.0 < np.median(errors[False])


def _random_power(traffic: Traffic, sigma_db: float, seed: int) -> Traffic:
    """The scene with the spoofer's every message at a power offset N(0, sigma^2)."""
    rng = np.random.default_rng(seed)
    cycles = {
        t: [
            dataclasses.replace(c, rssi_dbm=readonly(c.rssi_dbm + rng.normal(0.0, sigma_db)))
            if c.uas_id == SPOOFER_ID
            else c
            for c in claims
        ]
        for t, claims in traffic.cycles.items()
    }
    return Traffic(traffic.scene, traffic.paths, traffic.ids, cycles)


def _track_errors(traffic: Traffic, cfg: PipelineConfig, from_s: float) -> np.ndarray:
    pipeline = EstimationPipeline(cfg)
    errors = []
    for k in range(1, round(traffic.scene.duration_s / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out = pipeline.step(now, traffic.cycles.get(now, []))
        for track in out.tracks:
            if now >= from_s:
                errors.append(np.linalg.norm(track.p_enu_m - traffic.spoofer_path.at(now)))
    return np.array(errors)


def test_a_random_power_spoofer_is_still_localised_with_the_adaptive_jitter() -> None:
    traffic = _random_power(make_traffic(Scene(seed=6, n_receivers=12, duration_s=60.0)), 6.0, 1)
    forced = ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0)
    off = _track_errors(traffic, PipelineConfig(forced_alert=forced), 20.0)
    adaptive = _track_errors(
        traffic,
        PipelineConfig(
            forced_alert=forced, rssi_filter=RssiFilterConfig(tx_power_jitter="adaptive")
        ),
        20.0,
    )
    rmse_off, rmse_adaptive = (float(np.sqrt(np.mean(e**2))) for e in (off, adaptive))
    assert adaptive.size > 100
    assert rmse_adaptive < 0.5 * rmse_off and rmse_adaptive < 60.0


def test_a_silent_spoofer_coasts_with_a_growing_region_until_it_is_too_wide() -> None:
    traffic = make_traffic(Scene(seed=2, n_receivers=10, duration_s=60.0))
    for t in list(traffic.cycles):  # the spoofer goes quiet after 20 s
        if t > 20.0:
            traffic.cycles[t] = [c for c in traffic.cycles[t] if c.uas_id != SPOOFER_ID]
    cfg = PipelineConfig(
        forced_alert=ForcedAlertConfig(enabled=True, uas_id=SPOOFER_ID, time_s=2.0),
        tracks=TrackConfig(coast_max_radius_m=150.0),
    )
    pipeline = EstimationPipeline(cfg)
    widths, deleted = [], None
    for k in range(1, round(60.0 / CYCLE_S) + 1):
        now = round(k * CYCLE_S, 6)
        out = pipeline.step(now, traffic.cycles.get(now, []))
        if SPOOFER_ID in out.deleted_tracks:
            deleted = now
        for region in out.regions:
            if now > 21.0:
                widths.append((now, float(region.semi_axes_m.max())))
    assert deleted is not None and deleted > 31.0  # past the 10 s silence timeout
    times = [t for t, _ in widths]
    assert times == sorted(times) and times[-1] < deleted
    sizes = np.array([w for _, w in widths])
    assert np.all(np.diff(sizes) >= -1e-6)  # grows while nothing is heard
    assert sizes[-1] <= 150.0
