"""The antennas' gain off level, learned on the cooperative aircraft
(``calibration.elevation_knots_deg``): the fit recovers a pattern's loss by elevation, and
the claims' RSSI is mapped with it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.pathloss import dipole_gain_dbi
from ridsafe.gcs.calibration.channel_fit import fit_channel
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller, link_elevation_deg
from ridsafe.gcs.calibration.pipeline import CalibratingPipeline, _TrackNoise, to_free_space_all
from ridsafe.gcs.pipeline_api import FORGET_AFTER_S, ObservedClaim, for_tracks
from ridsafe.gcs.pipeline_config import PipelineConfig
from ridsafe.gcs.synthetic.traffic import Scene, Traffic, make_traffic
from tests.gcs.calibration.links import random_links
from tests.gcs.claims import free_space_claim

KNOTS = (0.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0)
CFG = CalibrationConfig(enabled=True, min_samples=200, min_time_s=0.0, elevation_knots_deg=KNOTS)


def _dipoles(seed: int, k: int = 4000) -> tuple[np.ndarray, ...]:
    """Vertical half-wave dipoles at both ends, level aircraft: the link at elevation e sees
    each antenna at 90 - e degrees from its axis. Free space, 1 dB."""
    rng = np.random.default_rng(seed)
    level, tx, rx, d = random_links(rng, 12, k, -20.0, (40.0, 800.0))
    elevation = np.degrees(np.arcsin(rng.uniform(0.0, 0.8, k) ** 2))  # mostly near level
    pattern = 2.0 * (dipole_gain_dbi(np.sin(np.radians(elevation))) - dipole_gain_dbi(0.0))
    rssi = level[tx - 1] - 20.0 * np.log10(d) + pattern + rng.normal(0.0, 1.0, k)
    return tx, rx, d, rssi, elevation, pattern


def test_the_fit_recovers_the_patterns_loss_by_elevation() -> None:
    tx, rx, d, rssi, elevation, pattern = _dipoles(1)
    est = fit_channel(tx, rx, d, rssi, CFG, elevation)
    assert est.elevation_knots_deg == KNOTS
    # The fitted gain against the true one where links are (up to 50 degrees here).
    seen = elevation <= 45.0
    error = est.elevation_gain_of(elevation[seen]) - pattern[seen]
    assert np.sqrt(np.mean(error**2)) < 0.3
    assert est.exponent == pytest.approx(2.0, abs=0.03)
    assert est.sigma_db == pytest.approx(1.0, rel=0.1)
    # Without it the pattern's loss is noise, and the steep links bend the exponent.
    plain = fit_channel(tx, rx, d, rssi, dataclasses.replace(CFG, elevation_knots_deg=()))
    assert plain.sigma_db > 1.3 * est.sigma_db
    assert plain.elevation_gain_of(elevation).tolist() == [0.0] * elevation.shape[0]


def test_a_knot_the_receptions_cannot_tell_from_zero_is_held_at_zero() -> None:
    """Isotropic antennas, the fleet on its pads but for a few early steep links (the first
    fit of a run): their noise would be a gain applied to every later link at those
    elevations. Oracle: the true gain, 0 dB everywhere."""
    rng = np.random.default_rng(3)
    n, k = 8, 600
    tx = rng.integers(1, n + 1, k)
    rx = (tx + rng.integers(1, n, k) - 1) % n + 1
    d = rng.uniform(40.0, 800.0, k)
    elevation = np.where(np.arange(k) < 12, rng.uniform(15.0, 70.0, k), 0.0)
    rssi = -20.0 - 20.0 * np.log10(d) + rng.normal(0.0, 1.0, k)
    held = fit_channel(tx, rx, d, rssi, CFG, elevation)
    assert held.elevation_gain_db == (0.0,) * len(KNOTS)
    as_fitted = fit_channel(
        tx, rx, d, rssi, dataclasses.replace(CFG, elevation_gain_min_z=0.0), elevation
    )
    assert max(abs(g) for g in as_fitted.elevation_gain_db) > 0.3  # what it held back
    # A pattern the receptions do resolve is kept (the dipoles above, at every seed tried).
    tx, rx, d, rssi, elevation, pattern = _dipoles(4)
    kept = fit_channel(tx, rx, d, rssi, CFG, elevation)
    seen = elevation <= 45.0
    error = kept.elevation_gain_of(elevation[seen]) - pattern[seen]
    assert np.sqrt(np.mean(error**2)) < 0.3


def test_the_detectors_get_the_gain_at_the_claimed_elevation_the_tracks_do_not() -> None:
    tx, rx, d, rssi, elevation, _ = _dipoles(2)
    tested = fit_channel(tx, rx, d, rssi, CFG, elevation)
    plain = fit_channel(tx, rx, d, rssi, dataclasses.replace(CFG, elevation_knots_deg=()))
    receivers = {1: [300.0, 0.0, 60.0], 2: [50.0, 0.0, 110.0]}  # level, and 45 degrees up
    claim = free_space_claim("X", 0.0, [0.0, 0.0, 60.0], receivers)
    both = to_free_space_all([claim], plain, 0.0, tested)[0]
    tracks_only = to_free_space_all([claim], plain, 0.0)[0]
    assert tracks_only.track_rssi_dbm is None
    assert both.track_rssi_dbm is not None
    np.testing.assert_allclose(both.track_rssi_dbm, tracks_only.rssi_dbm)
    gain = tested.elevation_gain_of(np.array([0.0, 45.0]))
    without_gain = to_free_space_all([claim], dataclasses.replace(tested, elevation_knots_deg=()))
    np.testing.assert_allclose(
        both.rssi_dbm, without_gain[0].rssi_dbm - (2.0 / tested.exponent) * gain, atol=1e-9
    )
    assert gain[1] < -5.0  # two dipoles 45 degrees off their best: about -7 dB
    # What the tracks see: the claim with the tracks' RSSI.
    np.testing.assert_allclose(for_tracks(both).rssi_dbm, tracks_only.rssi_dbm)
    assert for_tracks(both).track_rssi_dbm is None


def test_the_labeller_keeps_each_links_elevation() -> None:
    positions = {1: [0.0, 0.0, 60.0], 2: [300.0, 0.0, 60.0], 3: [0.0, 100.0, 160.0]}
    lab = CooperativeLabeller(CFG)
    for k in range(5):
        for sysid, p in positions.items():
            others = {i: q for i, q in positions.items() if i != sysid}
            lab.observe(free_space_claim(f"RID{sysid}", float(k), p, others))
    s = lab.samples
    level = np.isin(s.tx_sysid, [1, 2]) & np.isin(s.rx_sysid, [1, 2])
    np.testing.assert_allclose(s.elevation_deg[level], 0.0, atol=1e-9)
    steep = (s.tx_sysid == 3) & (s.rx_sysid == 1)
    np.testing.assert_allclose(s.elevation_deg[steep], 45.0, atol=1e-9)
    assert link_elevation_deg(np.array([-100.0]), np.array([100.0]))[0] == pytest.approx(90.0)


@pytest.mark.parametrize("knots", [(10.0, 20.0), (0.0,), (0.0, 30.0, 20.0), (0.0, 95.0)])
def test_knots_must_start_level_and_ascend_to_at_most_90(knots: tuple[float, ...]) -> None:
    with pytest.raises(FieldValueError, match="elevation_knots_deg"):
        CalibrationConfig(elevation_knots_deg=knots)


def _with_pattern(claim: ObservedClaim, db_per_degree: float) -> ObservedClaim:
    """The claim with each reception's RSSI changed by ``db_per_degree`` times its link's
    elevation (truthful claims: the claimed position is the transmitter's)."""
    offsets = claim.rx_p_enu_m - claim.claimed_p_enu_m
    elevation = link_elevation_deg(offsets[:, 2], np.linalg.norm(offsets, axis=1))
    return dataclasses.replace(claim, rssi_dbm=claim.rssi_dbm + db_per_degree * elevation)


def _run(traffic: Traffic, cal: CalibrationConfig, db_per_degree: float) -> CalibratingPipeline:
    pipeline = CalibratingPipeline(PipelineConfig(calibration=cal))
    for now in sorted(traffic.cycles):
        pipeline.step(now, [_with_pattern(c, db_per_degree) for c in traffic.cycles[now]])
    return pipeline


def test_the_detectors_sigma_follows_the_pattern_the_tracks_noise_does_not() -> None:
    """Cooperative traffic through antennas that lose 0.4 dB per degree of elevation: the
    elevation fit explains the loss, so the detectors test with a smaller sigma, while the
    tracks, which get the RSSI without the gain, localise with the noise that RSSI shows,
    as they do without the elevation fit (measured on it by the detectors run again)."""
    traffic = make_traffic(Scene(seed=4, n_receivers=10, duration_s=40.0, with_spoofer=False))
    cal = CalibrationConfig(enabled=True, min_samples=100, elevation_knots_deg=KNOTS)
    with_fit = _run(traffic, cal, -0.4)
    without = _run(traffic, dataclasses.replace(cal, elevation_knots_deg=()), -0.4)
    assert with_fit.inner is not None and without.inner is not None
    assert with_fit.tested_estimate is not None and without.tested_estimate is None
    # The detectors: the pattern is no longer noise.
    assert with_fit.inner.config.rssi_sigma_db < 0.8 * without.inner.config.rssi_sigma_db
    # The tracks: the same noise as without the fit (within the runs' differences).
    assert with_fit.inner.config.localisation_noise_inflation > 1.5
    assert with_fit.inner.config.localisation_sigma_db == pytest.approx(
        without.inner.config.localisation_sigma_db, rel=0.1
    )


def test_the_tracks_noise_forgets_a_transmitter_the_pipeline_forgets() -> None:
    """The second detector pass keeps a transmitter's memory no longer than the inner
    pipeline does (``FORGET_AFTER_S`` of silence): new serials must not grow it."""
    receivers = {1: [300.0, 0.0, 60.0], 2: [0.0, 300.0, 60.0], 3: [-300.0, 0.0, 60.0]}
    noise = _TrackNoise(PipelineConfig(), CooperativeLabeller(CFG), 1.0)
    noise.observe([free_space_claim("OLD", 0.0, [0.0, 0.0, 60.0], receivers)])
    noise.observe([free_space_claim("NEW", FORGET_AFTER_S, [0.0, 0.0, 60.0], receivers)])
    assert set(noise.monitors) == {"OLD", "NEW"}
    noise.observe([free_space_claim("NEW", FORGET_AFTER_S + 1.0, [0.0, 0.0, 60.0], receivers)])
    assert set(noise.monitors) == {"NEW"}
