"""Spoofing detectors: the paper's formulas re-derived, the exact chi-square law of the
aggregated tests under H0 (seeded Monte-Carlo), the compiled kernel against the numpy
reference, and detection on recorded-style synthetic traffic: a spoofer with a constant
50 m offset is flagged, benign aircraft are not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ridsafe.common.messages import RidsafeDetector
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.detection.rssi_consistency import (
    PairNis,
    RssiConsistencyDetectors,
    implied_powers,
    offset_score_test,
    probit,
    spread_test,
    sufficient_statistics,
    surprisal,
)
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig
from ridsafe.gcs.synthetic.evaluate import run_pipeline
from ridsafe.gcs.synthetic.traffic import SPOOFER_ID, Scene, make_traffic
from tests.gcs.claims import observed_claim

PAPER = DetectionConfig(position_sigma_m=0.0)


def _rx(rng: np.random.Generator, k: int) -> np.ndarray:
    return np.column_stack((rng.uniform(-500, 500, (k, 2)), rng.uniform(30, 100, k)))


def _honest_rssi(
    rng: np.random.Generator, p: np.ndarray, rx: np.ndarray, sigma: float
) -> np.ndarray:
    d = np.linalg.norm(rx - p, axis=1)
    out: np.ndarray = received_power_dbm(20.0, d) + rng.normal(0, sigma, rx.shape[0])
    return out


def _claim(
    t: float, claimed: np.ndarray, rx: np.ndarray, rssi: np.ndarray, uas: str = "X"
) -> ObservedClaim:
    return observed_claim(uas, t, claimed, rx, rssi)


def test_implied_power_is_the_papers_inversion() -> None:
    rx = np.array([[0.0, 0.0, 0.0], [300.0, 400.0, 0.0]])
    ip = implied_powers(np.array([0.0, 0.0, 0.0]), rx, np.array([-50.0, -80.0]), 1.0, PAPER)
    # RSSI + 20 log10(d) + 40.04 with d clamped to 1 m.
    np.testing.assert_allclose(ip.y, [-50.0 + 40.04, -80.0 + 20 * math.log10(500.0) + 40.04])
    np.testing.assert_allclose(ip.w, 1.0)
    np.testing.assert_allclose(
        ip.g[1], 20 / math.log(10) * np.array([-300.0, -400.0, 0.0]) / 500.0**2
    )


def test_position_uncertainty_lowers_the_weight_of_close_receptions() -> None:
    cfg = DetectionConfig(position_sigma_m=2.0)
    rx = np.array([[5.0, 0.0, 0.0], [500.0, 0.0, 0.0]])
    ip = implied_powers(np.zeros(3), rx, np.array([-40.0, -80.0]), 1.0, cfg)
    expected = 1.0 / (1.0 + (20 / math.log(10) * 2.0 / np.array([5.0, 500.0])) ** 2)
    np.testing.assert_allclose(ip.w, expected)


def test_aggregated_tests_are_chi_square_under_h0() -> None:
    """Honest transmissions: the spread is chi2_{k-1}, the offset score test chi2_3 (exact,
    the null model is linear in Pt), across receivers and, summed, across a window."""
    rng = np.random.default_rng(42)
    k = 9
    rx = _rx(rng, k)
    p = np.array([30.0, -60.0, 60.0])
    spreads, scores, window_scores = [], [], []
    for _ in range(600):
        rows = []
        for _ in range(4):
            ip = implied_powers(p, rx, _honest_rssi(rng, p, rx, 1.0), 1.0, PAPER)
            rows.append(sufficient_statistics(ip, 20.0))
        t, dof = spread_test(rows[0])
        assert dof == k - 1
        spreads.append(t)
        T, rank, _ = offset_score_test(np.stack((rows[0], np.sum(rows, axis=0))))
        assert list(rank) == [3, 3]
        scores.append(T[0])
        window_scores.append(T[1])
    assert stats.kstest(spreads, stats.chi2(k - 1).cdf).pvalue > 1e-3
    assert stats.kstest(scores, stats.chi2(3).cdf).pvalue > 1e-3
    assert stats.kstest(window_scores, stats.chi2(3).cdf).pvalue > 1e-3


def test_offset_score_test_recovers_the_offset_direction() -> None:
    """A liar at c - delta: one Gauss-Newton step from the claim points back at delta."""
    rng = np.random.default_rng(1)
    rx = _rx(rng, 16)
    true = np.array([0.0, 0.0, 60.0])
    claimed = true + np.array([50.0, 50.0, 0.0])
    ip = implied_powers(claimed, rx, _honest_rssi(rng, true, rx, 0.0), 1.0, PAPER)
    T, rank, delta = offset_score_test(sufficient_statistics(ip, 20.0)[None])
    assert rank[0] == 3 and T[0] > stats.chi2.isf(1e-4, 3)  # noise-free: the noncentrality
    assert np.dot(delta[0][:2], [50.0, 50.0]) / (np.linalg.norm(delta[0][:2]) * 70.7) > 0.9


def test_co_located_receivers_reduce_the_rank() -> None:
    rx = np.repeat(np.array([[100.0, 0.0, 50.0], [0.0, 200.0, 50.0]]), 3, axis=0)
    ip = implied_powers(np.array([0.0, 0.0, 60.0]), rx, np.full(6, -70.0), 1.0, PAPER)
    _, rank, _ = offset_score_test(sufficient_statistics(ip, 20.0)[None])
    assert rank[0] == 1  # two places, one power: one direction left to test


def test_surprisal_and_probit() -> None:
    assert surprisal(float(stats.chi2.isf(1e-6, 3)), 3) == pytest.approx(6.0)
    assert surprisal(1e6, 3) == 300.0 and surprisal(5.0, 0) == 0.0
    assert probit(float(stats.chi2.isf(0.5, 4)), 4) == pytest.approx(0.0, abs=1e-9)
    assert probit(float(stats.chi2.isf(0.025, 2)), 2) == pytest.approx(1.96, abs=1e-3)


def test_pair_nis_is_the_papers_scalar_filter() -> None:
    """x0 = first y, P0 = 10; then P- = P + 0.01, NIS = nu^2 / (P- + 4), K = P- / (P- + 4)."""
    ys = [20.0, 21.5, 19.0, 24.0]
    pairs = PairNis(PAPER)
    got = []
    for y in ys:
        ip = implied_powers(
            np.zeros(3), np.array([[1000.0, 0, 0]]), np.array([y - 60.0 - 40.04]), 1.0, PAPER
        )
        got.append(pairs.step(np.array([7]), ip))
    x, P, expected = ys[0], 10.0, [0.0]
    for y in ys[1:]:
        P += 0.01
        expected.append((y - x) ** 2 / (P + 4.0))
        K = P / (P + 4.0)
        x, P = x + K * (y - x), (1 - K) * P
    np.testing.assert_allclose(got, expected, rtol=1e-9)


def test_kernel_matches_the_numpy_reference() -> None:
    rng = np.random.default_rng(9)
    cfg = DetectionConfig(window_s=4.5, long_window_s=6.5)
    monitor = RssiConsistencyDetectors("X", cfg, 1.0)
    reference = PairNis(cfg)
    true = np.array([10.0, 20.0, 60.0])
    rows: list[tuple[float, np.ndarray]] = []
    for t in range(8):
        rx = _rx(rng, 7)
        rssi = _honest_rssi(rng, true + np.array([0.0, 7.0 * t, 0.0]), rx, 1.0)
        claimed = true + np.array([40.0, 7.0 * t + 40.0, 0.0])
        results = {r.detector: r for r in monitor.observe(_claim(float(t), claimed, rx, rssi))}
        ip = implied_powers(claimed, rx, rssi, 1.0, cfg)
        y_ref = monitor._y_ref
        assert y_ref is not None
        rows.append((float(t), sufficient_statistics(ip, y_ref)))
        window = np.sum([r for s, r in rows if s > t - 4.5], axis=0)
        long_window = np.sum([r for s, r in rows if s > t - 6.5], axis=0)
        nis = reference.step(np.arange(1, 8, dtype=np.int64), ip)
        T, rank, _ = offset_score_test(np.stack((rows[-1][1], window, long_window)))
        assert results[RidsafeDetector.NIS].statistic == pytest.approx(nis, rel=1e-9)
        assert results[RidsafeDetector.POWER_SPREAD].statistic == pytest.approx(
            surprisal(*spread_test(rows[-1][1])), rel=1e-6
        )
        assert results[RidsafeDetector.NIS_WINDOW].statistic == pytest.approx(
            surprisal(*spread_test(window)), rel=1e-6
        )
        assert results[RidsafeDetector.MLAT].statistic == pytest.approx(
            surprisal(T[1], int(rank[1])), rel=1e-6
        )
        assert results[RidsafeDetector.MLAT_LONG].statistic == pytest.approx(
            surprisal(T[2], int(rank[2])), rel=1e-6
        )
    assert len(rows) > 6  # the long window held claims the short one had dropped


def test_without_a_long_window_there_is_no_long_window_result() -> None:
    rng = np.random.default_rng(3)
    rx = _rx(rng, 6)
    claim = _claim(0.0, np.zeros(3), rx, _honest_rssi(rng, np.zeros(3), rx, 1.0))
    detectors = [r.detector for r in RssiConsistencyDetectors("X", PAPER, 1.0).observe(claim)]
    assert detectors == list(RssiConsistencyDetectors.DETECTORS)


@pytest.mark.parametrize("seed", [1, 5])
def test_a_weak_lie_the_short_window_misses_is_caught_by_the_long_window(seed: int) -> None:
    """A 35 m lie under 2 dB noise (synthetic traffic, 8 receivers, 60 s): the 10 s window
    alerts late (seed 1) or never (seed 5); with a 30 s window MLAT_LONG alerts first, and
    nobody honest is flagged."""
    traffic = make_traffic(
        Scene(
            seed=seed,
            n_receivers=8,
            duration_s=60.0,
            sigma_db=2.0,
            spoofer_offset_enu_m=(25.0, 25.0, 0.0),
        )
    )
    short = run_pipeline(traffic, PipelineConfig(rssi_sigma_db=2.0))
    both = run_pipeline(
        traffic,
        PipelineConfig(rssi_sigma_db=2.0, detection=DetectionConfig(long_window_s=30.0)),
    )
    assert both.alert_detector is RidsafeDetector.MLAT_LONG
    assert math.isnan(short.delay_s) or both.delay_s < short.delay_s - 1.0
    assert short.false_alerts == both.false_alerts == 0


def test_few_receivers_are_not_tested() -> None:
    monitor = RssiConsistencyDetectors("X", DetectionConfig(min_receivers=3), 1.0)
    rx = np.array([[0.0, 0, 50], [100.0, 0, 50]])
    assert monitor.observe(_claim(0.0, np.zeros(3), rx, np.array([-60.0, -70.0]))) == ()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_spoofer_with_a_constant_offset_is_flagged_and_benign_aircraft_are_not(seed: int) -> None:
    """Recorded-style synthetic traffic (the sim radio's model, 16 receivers, 60 s)."""
    traffic = make_traffic(Scene(seed=seed, n_receivers=16, duration_s=60.0))
    metrics = run_pipeline(traffic, PipelineConfig(), keep_results=True)
    assert metrics.alert_detector is not None
    assert metrics.delay_s < 15.0
    assert metrics.false_alerts == 0
    benign_flags = [
        r
        for spoofer, r in metrics.results
        if not spoofer and r.decision and r.detector in PipelineConfig().detection.alerting
    ]
    assert benign_flags == []
    spoofer_flags = [
        r
        for spoofer, r in metrics.results
        if spoofer and r.detector is RidsafeDetector.MLAT and r.decision
    ]
    assert len(spoofer_flags) > 10
    assert all(r.uas_id == SPOOFER_ID for r in spoofer_flags)


def test_config_validation_names_the_field() -> None:
    with pytest.raises(ValueError, match=r"alerting\[0\]"):
        DetectionConfig(alerting=(RidsafeDetector.FORCED,))
    with pytest.raises(ValueError, match="p_false_alarm"):
        DetectionConfig(p_false_alarm=0.7)
    with pytest.raises(ValueError, match="long_window_s"):
        DetectionConfig(window_s=10.0, long_window_s=10.0)
