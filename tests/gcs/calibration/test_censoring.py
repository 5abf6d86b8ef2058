"""Receptions near the receivers' sensitivity (``calibration.sensitivity_lift``): the lift
of what survives the cut, the fit and the detectors' RSSI corrected for it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import truncnorm

from ridsafe.gcs.calibration.censoring import (
    NEGLIGIBLE_LIFT_SIGMA,
    SensitivityFloor,
    claim_medians,
    expected_lift_db,
    lift_at_claims,
    significant_lift_db,
)
from ridsafe.gcs.calibration.channel_fit import Design, fit_channel
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline, to_free_space_all
from ridsafe.gcs.pipeline_api import reception_bounds
from ridsafe.gcs.pipeline_config import PipelineConfig
from tests.gcs.calibration.links import random_links
from tests.gcs.claims import observed_claim

CFG = CalibrationConfig(enabled=True, min_samples=200, min_time_s=0.0, elevation_knots_deg=())
CUT_DBM = -95.0


@pytest.mark.parametrize("alpha", [-4.0, -2.0, -0.5, 0.0, 1.0, 3.0])
def test_the_lift_is_the_truncated_normals_mean_less_the_mean(alpha: float) -> None:
    mean, sigma = -90.0, 2.0
    floor = mean + alpha * sigma
    expected = truncnorm.mean(alpha, np.inf, loc=mean, scale=sigma) - mean
    lift = expected_lift_db(np.array([mean]), floor, sigma)[0]
    assert lift == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_the_lift_matches_a_cut_applied_to_draws() -> None:
    rng = np.random.default_rng(3)
    mean, sigma = -94.0, 1.5
    draws = mean + sigma * rng.standard_normal(400_000)
    survived = draws[draws >= CUT_DBM]
    lift = expected_lift_db(np.array([mean]), CUT_DBM, sigma)[0]
    assert np.mean(survived) - mean == pytest.approx(lift, abs=0.01)
    assert lift > 0.5  # a mean 1 dB above the cut, a third of a sigma lifted


def test_no_floor_and_links_far_above_it_are_not_lifted() -> None:
    means = np.array([-60.0, -80.0])
    assert expected_lift_db(means, -math.inf, 1.0).tolist() == [0.0, 0.0]
    assert expected_lift_db(means, -95.0, 1.0).max() < 1e-20
    # Far below the cut the lift is taken at MAX_ALPHA sigma: finite, about c - mu there.
    deep = expected_lift_db(np.array([-200.0]), CUT_DBM, 1.0)[0]
    assert math.isfinite(deep) and 4.0 < deep < 4.3


def _links(seed: int, exponent: float, cut_dbm: float, k: int = 12_000) -> tuple[np.ndarray, ...]:
    """Receptions of 12 transmitters by 12 receivers at 30-900 m, 1 dB noise, with only those
    at or above ``cut_dbm`` reported."""
    rng = np.random.default_rng(seed)
    level, tx, rx, d = random_links(rng, 12, k, -10.0, (30.0, 900.0))
    rssi = level[tx - 1] - 10.0 * exponent * np.log10(d) + rng.normal(0.0, 1.0, k)
    kept = rssi >= cut_dbm
    return tx[kept], rx[kept], d[kept], rssi[kept], level


def test_the_fit_with_the_floor_recovers_the_exponent_the_cut_biases() -> None:
    tx, rx, d, rssi, level = _links(5, 3.0, CUT_DBM)
    near = np.mean(rssi < CUT_DBM + 3.0)
    assert near > 0.1  # the cut matters: a tenth of the receptions within 3 dB of it
    plain = fit_channel(tx, rx, d, rssi, CFG)
    corrected = fit_channel(tx, rx, d, rssi, CFG, floor_dbm=float(rssi.min()))
    assert plain.exponent < 2.98  # what survives the cut runs above the mean: far links
    assert corrected.exponent == pytest.approx(3.0, abs=0.015)
    fitted = np.array([corrected.tx_level_db[s] for s in range(1, 13)])
    biases = np.array(list(corrected.rx_bias_db.values()))
    # Level and bias share a gauge: compare the sums the data can tell.
    assert np.abs(fitted + np.mean(biases) - level).max() < 0.15
    assert corrected.sigma_db == pytest.approx(1.0, abs=0.05)


def test_without_a_cut_the_floor_leaves_the_fit_as_it_was() -> None:
    """The weakest RSSI is then a deep fade, several sigma below every link's mean: no lift
    reaches NEGLIGIBLE_LIFT_SIGMA, and the fit is the plain one, exactly."""
    tx, rx, d, rssi, _ = _links(6, 3.0, -math.inf)
    plain = fit_channel(tx, rx, d, rssi, CFG)
    assert fit_channel(tx, rx, d, rssi, CFG, floor_dbm=float(rssi.min())) == plain


def test_a_lift_under_the_negligible_fraction_of_sigma_is_not_applied() -> None:
    sigma = 2.0
    means = -95.0 + sigma * np.array([-1.0, 0.0, 1.5, 1.7, 5.0])
    full = expected_lift_db(means, -95.0, sigma)
    applied = significant_lift_db(means, -95.0, sigma)
    assert full.min() > 0.0
    np.testing.assert_array_equal(applied > 0.0, full >= NEGLIGIBLE_LIFT_SIGMA * sigma)
    assert applied.tolist()[:3] == full.tolist()[:3] and applied.tolist()[3:] == [0.0, 0.0]


def _heard_claims(seed: int, n_claims: int) -> tuple[list, np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    """Honest transmitters at level -10 dB, exponent 3, 1 dB, heard by 10 receivers each at
    100-900 m where the cut lets them; (claims, their receptions' loss, their mean RSSI)."""
    rng = np.random.default_rng(seed)
    claims, losses, means = [], [], []
    for j in range(n_claims):
        p = np.array([0.0, 0.0, 50.0])
        rx = p + np.column_stack([rng.uniform(100.0, 900.0, 10), np.zeros(10), np.zeros(10)])
        d = np.linalg.norm(rx - p, axis=1)
        mean = -10.0 - 30.0 * np.log10(d)
        rssi = mean + rng.standard_normal(10)
        kept = rssi >= CUT_DBM
        kept[: 10 if j == 3 else 0] = False  # one claim heard by no one
        ids = np.arange(1, 11, dtype=np.int64)[kept]
        claims.append(observed_claim("S", float(j), p, rx[kept], rssi[kept], ids))
        losses.append(30.0 * np.log10(d[kept]))
        means.append(mean[kept])
    return claims, np.concatenate(losses), np.concatenate(means)


def test_the_detectors_rssi_less_the_lift_is_centred_on_the_links_mean() -> None:
    claims, loss, mean = _heard_claims(8, 400)
    rssi = np.concatenate([c.rssi_dbm for c in claims])
    bounds = reception_bounds(claims)
    lift = lift_at_claims(rssi, bounds, loss, np.zeros_like(loss), CUT_DBM, 1.0)
    near = mean < CUT_DBM + 1.0
    assert np.mean(rssi[near] - mean[near]) > 0.5  # what the cut let through, unmodelled
    assert np.mean(rssi[near] - lift[near] - mean[near]) == pytest.approx(0.0, abs=0.1)
    far = mean > CUT_DBM + 5.0
    assert lift[far].tolist() == [0.0] * int(far.sum())
    assert lift_at_claims(rssi, bounds, loss, np.zeros_like(loss), -math.inf, 1.0).max() == 0.0


def test_the_floor_is_the_weakest_rssi_reported() -> None:
    claims, _, _ = _heard_claims(9, 20)
    floor = SensitivityFloor()
    assert floor.dbm == -math.inf
    floor.observe(claims[:10])
    floor.observe([])
    floor.observe(claims[10:])
    assert floor.dbm == min(float(c.rssi_dbm.min()) for c in claims if c.n_receivers)


def test_a_claim_with_a_non_finite_rssi_leaves_the_floor_to_the_others() -> None:
    claims, _, _ = _heard_claims(9, 20)
    heard = [c for c in claims if c.n_receivers >= 2]
    weakest = min(heard, key=lambda c: float(c.rssi_dbm.min()))
    rssi = weakest.rssi_dbm.copy()
    rssi[int(np.argmax(rssi))] = np.nan  # its weakest finite RSSI is still the fleet's weakest
    broken = dataclasses.replace(weakest, rssi_dbm=rssi)
    floor = SensitivityFloor()
    floor.observe([broken if c is weakest else c for c in claims])
    others = [c for c in heard if c is not weakest]
    assert floor.dbm == min(float(c.rssi_dbm.min()) for c in others)
    assert floor.dbm > float(weakest.rssi_dbm.min())


def test_the_pipeline_maps_the_detectors_rssi_less_the_lift_and_the_tracks_without() -> None:
    claims, loss, _ = _heard_claims(10, 30)
    tx, rx, d, rssi, _ = _links(11, 3.0, CUT_DBM)
    estimate = fit_channel(tx, rx, d, rssi, CFG, floor_dbm=CUT_DBM)
    mapped = to_free_space_all(claims, estimate, -10.0, None, CUT_DBM)
    plain = to_free_space_all(claims, estimate, -10.0)
    bias = np.concatenate([estimate.bias_of(c.rx_sysid) for c in claims])
    fitted_loss = 10.0 * estimate.exponent * np.log10(np.concatenate(
        [np.linalg.norm(c.rx_p_enu_m - c.claimed_p_enu_m, axis=1) for c in claims]
    ))  # fmt: skip
    rssi = np.concatenate([c.rssi_dbm for c in claims])
    bounds = reception_bounds(claims)
    lift = lift_at_claims(rssi, bounds, fitted_loss, bias, CUT_DBM, estimate.sigma_db)
    assert lift.max() > 0.5
    tested = np.concatenate([c.rssi_dbm for c in mapped])
    tracks = np.concatenate([c.track_rssi_dbm for c in mapped])
    as_before = np.concatenate([c.rssi_dbm for c in plain])
    np.testing.assert_allclose(tracks, as_before, atol=1e-12)
    np.testing.assert_allclose(as_before - tested, (2.0 / estimate.exponent) * lift, atol=1e-9)
    assert loss.shape == lift.shape


def test_the_censored_sample_is_the_rssi_mapped_without_the_lift_and_the_cut_likewise() -> None:
    """MLAT_CENSORED's input (``censored_sample``): the detectors' RSSI before the lift is
    taken, and the cut mapped by the same fit; none unless asked for."""
    claims, _, _ = _heard_claims(10, 30)
    tx, rx, d, rssi, _ = _links(11, 3.0, CUT_DBM)
    estimate = fit_channel(tx, rx, d, rssi, CFG, floor_dbm=CUT_DBM)
    sample = to_free_space_all(claims, estimate, -10.0, None, CUT_DBM, censored_sample=True)
    plain = to_free_space_all(claims, estimate, -10.0)
    assert all(c.cut_rssi_dbm is None for c in to_free_space_all(claims, estimate, -10.0))
    cut_rssi = np.concatenate([c.cut_rssi_dbm for c in sample if c.cut_rssi_dbm is not None])
    np.testing.assert_allclose(cut_rssi, np.concatenate([c.rssi_dbm for c in plain]), atol=1e-12)
    bias = np.concatenate([estimate.bias_of(c.rx_sysid) for c in claims])
    floor = np.concatenate([c.cut_floor_dbm for c in sample if c.cut_floor_dbm is not None])
    expected = -10.0 + (2.0 / estimate.exponent) * (CUT_DBM - bias + 10.0)
    np.testing.assert_allclose(floor, expected, atol=1e-12)
    assert np.all(cut_rssi >= floor - 1e-9)  # nothing under the cut was reported


def test_the_lift_is_a_setting() -> None:
    on = CalibratingPipeline(PipelineConfig(calibration=CFG))
    off = CalibratingPipeline(
        PipelineConfig(calibration=dataclasses.replace(CFG, sensitivity_lift=False))
    )
    claims = [c for c in _heard_claims(12, 5)[0] if c.n_receivers]
    for pipeline in (on, off):
        pipeline.step(0.0, claims)
    assert on._floor_dbm() == min(float(c.rssi_dbm.min()) for c in claims)
    assert off._floor_dbm() == -math.inf


def _dense(design: Design) -> np.ndarray:
    """The design as the dense matrix it stands for."""
    k = design.dense.shape[0]
    out = np.zeros((k, design.n_params))
    out[np.arange(k), design.tx_col] = 1.0
    out[np.arange(k), design.n_tx + design.rx_col] = 1.0
    out[:, design.n_tx + design.n_rx :] = design.dense
    return out


def test_the_designs_group_sums_are_the_dense_matrix_products() -> None:
    """``channel_fit.Design`` (the normal equations from group sums) against the dense
    design matrix it stands for."""
    rng = np.random.default_rng(13)
    tx, rx, d, _, _ = _links(13, 3.0, CUT_DBM, k=3000)
    _, tx_col = np.unique(tx, return_inverse=True)
    _, rx_col = np.unique(rx, return_inverse=True)
    dense = np.column_stack([-10.0 * np.log10(d), rng.uniform(0.0, 1.0, (d.shape[0], 3))])
    design = Design(tx_col, rx_col, int(tx_col.max()) + 1, int(rx_col.max()) + 1, dense)
    matrix = _dense(design)
    n = int(d.shape[0])
    w = rng.uniform(0.2, 1.5, size=(n,))
    v = rng.normal(0.0, 1.0, size=(n,))
    theta = rng.normal(0.0, 1.0, design.n_params)
    np.testing.assert_allclose(design.gram(w), matrix.T @ (matrix * w[:, None]), rtol=1e-12)
    np.testing.assert_allclose(design.transpose_times(v), matrix.T @ v, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(design.predict(theta), matrix @ theta, rtol=1e-12, atol=1e-12)


def test_claim_medians_are_numpys_median_of_each_claim() -> None:
    rng = np.random.default_rng(14)
    counts = np.array([1, 2, 5, 0, 6, 3])
    bounds = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    values = rng.normal(0.0, 5.0, int(counts.sum()))
    expected = np.concatenate(
        [
            np.full(c, np.median(values[lo : lo + c]))
            for lo, c in zip(bounds[:-1], counts, strict=True)
            if c
        ]
    )
    np.testing.assert_array_equal(claim_medians(values, bounds), expected)
