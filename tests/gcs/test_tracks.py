"""Tracks: initiation from recent claims, coasting between them, deletion on silence,
for every registered estimator."""

from __future__ import annotations

import numpy as np
import pytest

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.localisation.registry import ESTIMATORS
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.tracks import initiate


def _traffic(n_rx: int = 10, seconds: int = 12, seed: int = 0) -> list[ObservedClaim]:
    rng = np.random.default_rng(seed)
    rx = np.column_stack((rng.uniform(-500, 500, (n_rx, 2)), rng.uniform(30, 100, n_rx)))
    out = []
    for t in range(seconds):
        p = np.array([-200.0 + 7.0 * t, 50.0, 60.0])
        d = np.linalg.norm(rx - p, axis=1)
        rssi = received_power_dbm(20.0, d) + rng.normal(0, 1.0, n_rx)
        out.append(
            ObservedClaim(
                "S",
                t + 0.3,
                readonly(p + 50.0),
                None,
                np.arange(1, n_rx + 1),
                readonly(rx),
                readonly(np.full(n_rx, t + 0.3)),
                readonly(rssi),
            )
        )
    return out


@pytest.mark.parametrize("estimator", sorted(ESTIMATORS))
def test_initiation_coasting_and_silence(estimator: str) -> None:
    cfg = PipelineConfig(estimator=estimator)
    claims = _traffic()
    track = initiate("S", 7, claims[:6], cfg)
    assert track is not None and track.track_id == 7 and track.uas_id == "S"
    assert track.last_heard_s == pytest.approx(5.3)
    coasting = [track.estimate(t) for t in (5.5, 6.0, 8.0)]
    spread = [np.trace(e.cov_enu_m2) for e in coasting]
    assert spread[0] < spread[1] < spread[2]  # uncertainty grows while coasting
    track.fixed_this_cycle = False
    assert not track.estimate(6.0).fix
    assert track.update(claims[6]) and track.last_fix_s == pytest.approx(6.3)
    est = track.estimate(6.5)
    assert est.fix and est.mode_probabilities.sum() == pytest.approx(1.0)
    truth = np.array([-200.0 + 7.0 * 6.5, 50.0, 60.0])
    assert np.linalg.norm(est.p_enu_m[:2] - truth[:2]) < 80.0
    assert not track.silent(6.3 + cfg.tracks.silence_timeout_s - 0.1, cfg)
    assert track.silent(6.3 + cfg.tracks.silence_timeout_s + 0.1, cfg)


@pytest.mark.parametrize("estimator", sorted(ESTIMATORS))
def test_no_track_without_enough_receivers(estimator: str) -> None:
    cfg = PipelineConfig(estimator=estimator)
    assert initiate("S", 1, _traffic(n_rx=3, seconds=4), cfg) is None
