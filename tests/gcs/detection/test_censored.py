"""MLAT_CENSORED: a liar heard only near the receivers' cut is caught on the censored
likelihood, the same transmitter telling the truth is not; no result where no cut is known,
where the window holds too few receivers, or where no reception is near its cut; off by
default. Claims are drawn on the calibrated (free-space) scale the detector reads."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ridsafe.common.messages import RidsafeDetector
from ridsafe.gcs.detection.censored import CensoredLikelihoodDetector
from ridsafe.gcs.detection.rssi_state import RING
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig

SIGMA_DB = 0.7
FLOOR_DBM = -70.0
#: Power less the 1 m loss: heard down to about 330 m on the free-space scale.
POWER_DBM = -19.5
RECEIVERS = np.array(
    [[120.0 * i, 120.0 * j, 50.0] for i in range(-2, 3) for j in range(-2, 3)], dtype=np.float64
)
CONFIG = PipelineConfig(rssi_sigma_db=SIGMA_DB, detection=DetectionConfig(censored_window_s=10.0))


def _claim(
    t_s: float, true_p: np.ndarray, claimed_p: np.ndarray, rng: np.random.Generator
) -> ObservedClaim:
    d = np.maximum(np.linalg.norm(true_p - RECEIVERS, axis=1), 1.0)
    rssi = POWER_DBM - 20.0 * np.log10(d) + rng.normal(0.0, SIGMA_DB, d.shape[0])
    heard = np.flatnonzero(rssi >= FLOOR_DBM)
    return ObservedClaim(
        uas_id="X",
        rid_timestamp_s=t_s,
        claimed_p_enu_m=claimed_p,
        claimed_v_enu_m_s=None,
        rx_sysid=heard.astype(np.int64) + 1,
        rx_p_enu_m=RECEIVERS[heard],
        rx_t_s=np.full(heard.shape[0], t_s),
        rssi_dbm=rssi[heard],  # what MLAT would test (its lift not taken here)
        cut_rssi_dbm=rssi[heard],
        cut_floor_dbm=np.full(heard.shape[0], FLOOR_DBM),
    )


def _surprisals(claimed_offset: np.ndarray, seed: int) -> list[float]:
    rng = np.random.default_rng(seed)
    true_p = np.array([-380.0, -250.0, 60.0])
    detector = CensoredLikelihoodDetector("X", CONFIG)
    out = []
    for k in range(10):
        for r in detector.observe(_claim(float(k), true_p, true_p + claimed_offset, rng)):
            assert r.detector is RidsafeDetector.MLAT_CENSORED and r.threshold == 6.0
            assert r.decision == (r.statistic > 6.0)
            out.append(r.statistic)
    return out


def test_a_liar_heard_near_the_cut_is_caught_and_the_truthful_transmitter_is_not() -> None:
    liar = [max(_surprisals(np.array([50.0, 50.0, 0.0]), seed)) for seed in range(6)]
    honest = [max(_surprisals(np.zeros(3), seed)) for seed in range(6)]
    assert np.median(liar) > 6.0
    assert max(honest) < 6.0


def test_nothing_is_tested_without_a_cut_too_few_receivers_or_none_near_the_cut() -> None:
    rng = np.random.default_rng(0)
    p = np.array([-420.0, -300.0, 60.0])
    claim = _claim(0.0, p, p, rng)
    assert claim.n_receivers == 5  # heard near the cut by five of the grid
    detector = CensoredLikelihoodDetector("X", CONFIG)
    assert detector.observe(dataclasses.replace(claim, cut_rssi_dbm=None)) == ()
    two = dataclasses.replace(
        claim,
        rx_sysid=claim.rx_sysid[:2],
        rx_p_enu_m=claim.rx_p_enu_m[:2],
        rx_t_s=claim.rx_t_s[:2],
        rssi_dbm=claim.rssi_dbm[:2],
        cut_rssi_dbm=claim.cut_rssi_dbm[:2] if claim.cut_rssi_dbm is not None else None,
        cut_floor_dbm=np.full(2, FLOOR_DBM),
    )
    assert CensoredLikelihoodDetector("X", CONFIG).observe(two) == ()
    far_below = dataclasses.replace(claim, cut_floor_dbm=np.full(claim.n_receivers, -200.0))
    assert CensoredLikelihoodDetector("X", CONFIG).observe(far_below) == ()
    assert len(CensoredLikelihoodDetector("X", CONFIG).observe(claim)) == 1


def test_a_transmitter_claiming_fast_holds_at_most_the_ring_of_claims() -> None:
    rng = np.random.default_rng(2)
    p = np.array([-380.0, -250.0, 60.0])
    detector = CensoredLikelihoodDetector("X", CONFIG)
    for k in range(RING + 40):  # all within one second
        detector.observe(_claim(k / 200.0, p, p, rng))
    assert detector.window_claims == RING


def test_it_is_off_by_default_and_a_negative_window_is_refused() -> None:
    assert CensoredLikelihoodDetector.for_transmitter("X", PipelineConfig()) is None
    assert CensoredLikelihoodDetector.for_transmitter("X", CONFIG) is not None
    with pytest.raises(ValueError, match="censored_window_s"):
        DetectionConfig(censored_window_s=-1.0)
    assert math.isclose(DetectionConfig().censored_margin_sigma, 3.0)
