"""Channel calibration: the fit recovers a known channel, the labeller finds the cooperative
aircraft and never the spoofer, the calibrating pipeline maps RSSI onto free space."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ridsafe.gcs.calibration.channel_fit import ChannelEstimate, fit_channel
from ridsafe.gcs.calibration.config import CalibrationConfig
from ridsafe.gcs.calibration.cooperative import CooperativeLabeller
from ridsafe.gcs.calibration.pipeline import (
    CalibratingPipeline,
    make_pipeline,
    to_free_space,
    to_free_space_all,
)
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import ObservedClaim, readonly
from ridsafe.gcs.pipeline_config import PipelineConfig
from tests.gcs.claims import free_space_claim

CFG = CalibrationConfig(enabled=True, min_samples=200, min_time_s=0.0)


def _synthetic(
    seed: int, exponent: float, bias_std: float, sigma: float, n: int = 12, k: int = 4000
) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    bias = rng.normal(0.0, bias_std, n)
    bias -= bias.mean()
    level = 20.0 - 40.0 + rng.normal(0.0, 1.5, n)
    tx = rng.integers(1, n + 1, k)
    rx = (tx + rng.integers(1, n, k) - 1) % n + 1
    d = rng.uniform(30.0, 900.0, k)
    rssi = level[tx - 1] + bias[rx - 1] - 10 * exponent * np.log10(d) + rng.normal(0, sigma, k)
    return tx, rx, d, rssi, bias, level


@pytest.mark.parametrize(("exponent", "bias_std", "sigma"), [(2.0, 0.0, 1.0), (3.0, 4.0, 4.0)])
def test_fit_recovers_exponent_biases_and_sigma(
    exponent: float, bias_std: float, sigma: float
) -> None:
    tx, rx, d, rssi, bias, level = _synthetic(1, exponent, bias_std, sigma)
    est = fit_channel(tx, rx, d, rssi, CFG)
    assert est.exponent == pytest.approx(exponent, abs=4 * est.exponent_std + 0.01)
    assert est.sigma_db == pytest.approx(sigma, rel=0.05)
    fitted = np.array([est.rx_bias_db[s] for s in range(1, 13)])
    assert np.max(np.abs(fitted - bias)) < 0.5 + 0.05 * bias_std
    levels = np.array([est.tx_level_db[s] for s in range(1, 13)])
    np.testing.assert_allclose(levels - levels.mean(), level - level.mean(), atol=0.6)


def test_fit_is_robust_to_deep_fades() -> None:
    """10 % of receptions 15 dB down: the exponent barely moves, the RMS sigma reports them."""
    tx, rx, d, rssi, _, _ = _synthetic(2, 2.5, 2.0, 1.0)
    faded = rssi.copy()
    faded[::10] -= 15.0
    est = fit_channel(tx, rx, d, faded, CFG)
    assert est.exponent == pytest.approx(2.5, abs=0.05)
    assert est.robust_scale_db < 2.0
    assert est.sigma_db > 4.0


def test_labeller_finds_cooperative_aircraft_and_not_the_spoofer() -> None:
    positions = {1: [0.0, 0.0, 50.0], 2: [300.0, 0.0, 60.0], 3: [0.0, 400.0, 70.0]}
    lab = CooperativeLabeller(CFG)
    for k in range(5):
        t = float(k)
        for sysid, p in positions.items():
            others = {i: q for i, q in positions.items() if i != sysid}
            lab.observe(free_space_claim(f"RID{sysid}", t, p, others))
        # The spoofer claims a place 50 m from anyone and is heard by all three.
        lab.observe(free_space_claim("SPOOF", t, [150.0, 150.0, 60.0], positions))
    assert lab.labels() == {"RID1": 1, "RID2": 2, "RID3": 3}
    # The first min_matches - 1 matches only vote; later ones give samples (2 receivers
    # each). RID1's first claim matches nobody: nobody had reported RID1's position yet.
    assert len(lab.samples) == ((4 - 2) + (5 - 2) * 2) * 2
    assert set(lab.samples.tx_sysid) == {1, 2, 3}


def test_to_free_space_undoes_exponent_and_bias() -> None:
    tx, rx, d, rssi, _, _ = _synthetic(3, 3.0, 3.0, 0.01)
    est = fit_channel(tx, rx, d, rssi, CFG)
    claim = free_space_claim(
        "X", 0.0, [0.0, 0.0, 50.0], {1: [100.0, 0.0, 50.0], 2: [0.0, 700.0, 50.0]}
    )
    raw = claim.rssi_dbm * 1.5 + est.bias_of(claim.rx_sysid)  # exponent 3 from exponent 2
    mapped = to_free_space(
        ObservedClaim(
            claim.uas_id,
            0.0,
            claim.claimed_p_enu_m,
            None,
            claim.rx_sysid,
            claim.rx_p_enu_m,
            claim.rx_t_s,
            readonly(raw),
        ),
        est,
    )
    # Differences between receivers are the free-space ones: 20 log10(700/100).
    diff = mapped.rssi_dbm[0] - mapped.rssi_dbm[1]
    assert diff == pytest.approx(
        20 * math.log10(7.0) * 3.0 / est.exponent * (est.exponent / 3.0), abs=0.05
    )


def test_a_cycle_is_mapped_as_its_claims_one_by_one() -> None:
    """Mapped together, each claim gets the formula's values for its own receptions: a bias
    per receiver (0 for one never fitted, system ids beyond a byte included), exponent and
    pivot as given."""
    rng = np.random.default_rng(3)
    biases = {int(s): float(rng.normal(0.0, 3.0)) for s in rng.choice(np.arange(1, 300), 40)}
    est = ChannelEstimate(2.7, 0.1, biases, {}, 3.0, 2.5, 1000)
    claims = []
    for k in range(30):
        n = int(rng.integers(0, 8))
        high = 300 if k % 10 == 0 else 256  # every tenth with ids no byte holds
        claims.append(
            ObservedClaim(
                f"RID{k}",
                0.0,
                readonly(np.zeros(3)),
                None,
                rng.integers(1, high, n).astype(np.int64),
                readonly(rng.normal(0.0, 300.0, (n, 3))),
                readonly(np.zeros(n)),
                readonly(rng.normal(-70.0, 10.0, n)),
            )
        )
    mapped = to_free_space_all(claims, est, -45.0)
    assert len(mapped) == len(claims)
    for claim, out in zip(claims, mapped, strict=True):
        bias = np.array([biases.get(int(s), 0.0) for s in claim.rx_sysid])
        expected = (2.0 / 2.7) * (claim.rssi_dbm - bias - (-45.0)) + (-45.0)
        assert np.array_equal(out.rssi_dbm, expected)
        assert not out.rssi_dbm.flags.writeable
        assert out.rx_sysid is claim.rx_sysid and out.uas_id == claim.uas_id
        assert np.array_equal(to_free_space(claim, est, -45.0).rssi_dbm, expected)
    assert to_free_space_all([], est) == []


@pytest.mark.parametrize("floor_dbm", [-math.inf, -95.0])
def test_the_tracks_may_hold_to_a_fit_of_their_own(floor_dbm: float) -> None:
    """With ``tracks``: the detectors' RSSI mapped by the current fit, the tracks' by the one
    they hold to (with or without the sensitivity's lift corrected for the detectors)."""
    rng = np.random.default_rng(4)
    now = ChannelEstimate(2.7, 0.1, {1: 2.0, 2: -1.0, 3: 0.5}, {}, 3.0, 2.5, 1000)
    held = ChannelEstimate(2.2, 0.1, {1: -1.0, 2: 1.5, 3: 0.0}, {}, 3.0, 2.5, 300)
    claim = free_space_claim(
        "X", 0.0, [0.0, 0.0, 50.0], {1: [100.0, 0.0, 50.0], 2: [0.0, 700.0, 50.0], 3: [9, 9, 9]}
    )
    claim = replace(claim, rssi_dbm=readonly(claim.rssi_dbm + rng.normal(0.0, 2.0, 3)))
    (out,) = to_free_space_all([claim], now, -45.0, None, floor_dbm, held)
    (plain,) = to_free_space_all([claim], now, -45.0, None, floor_dbm)
    (as_held,) = to_free_space_all([claim], held, -45.0)
    assert np.array_equal(out.rssi_dbm, plain.rssi_dbm)
    assert out.track_rssi_dbm is not None
    assert np.array_equal(out.track_rssi_dbm, as_held.rssi_dbm)
    (same,) = to_free_space_all([claim], now, -45.0, None, -math.inf, now)
    assert same.track_rssi_dbm is None and np.array_equal(same.rssi_dbm, plain.rssi_dbm)


def test_make_pipeline_honours_the_enable_flag() -> None:
    off = CalibrationConfig(enabled=False)
    assert isinstance(make_pipeline(PipelineConfig(calibration=off)), EstimationPipeline)
    assert isinstance(make_pipeline(PipelineConfig()), CalibratingPipeline)  # auto
    on = make_pipeline(PipelineConfig(calibration=CFG))
    assert isinstance(on, CalibratingPipeline)
    # Before calibrating it holds claims and answers nothing.
    out = on.step(
        0.25, [free_space_claim("SPOOF", 0.0, [150.0, 150.0, 60.0], {1: [0.0, 0.0, 50.0]})]
    )
    assert out.alert_changes == () and out.regions == ()


def test_fit_sigma_is_unbiased_with_few_samples() -> None:
    """200 receptions, 25 parameters: RSS / K would be 12 % low in variance; RSS / (K - p)
    is right on average (20 seeds: the mean variance within 5 %)."""
    variances = []
    for seed in range(20):
        tx, rx, d, rssi, _, _ = _synthetic(10 + seed, 2.0, 2.0, 2.0, k=200)
        variances.append(fit_channel(tx, rx, d, rssi, CFG).sigma_db ** 2)
    assert float(np.mean(variances)) == pytest.approx(4.0, rel=0.05)


@pytest.mark.parametrize("n_aircraft", [3, 6])
def test_warm_up_scales_with_the_parameters_fitted(n_aircraft: int) -> None:
    """The fit waits for ``samples_per_parameter`` receptions per parameter (1 exponent +
    a bias per receiver + a level per transmitter): a fleet twice the size waits for about
    twice the receptions, not a fixed count."""
    cal = CalibrationConfig(enabled=True, min_samples=1, min_time_s=0.0, samples_per_parameter=5)
    pipeline = CalibratingPipeline(PipelineConfig(calibration=cal))
    positions = {i: [100.0 * i, 50.0 * (i % 2), 50.0] for i in range(1, n_aircraft + 1)}
    samples_before = 0
    for k in range(40):
        samples_before = len(pipeline.labeller.samples)
        claims = [
            free_space_claim(f"RID{i}", float(k), p, {j: q for j, q in positions.items() if j != i})
            for i, p in positions.items()
        ]
        pipeline.step(float(k) + 0.25, claims)
        if pipeline.inner is not None:
            break
    assert pipeline.inner is not None
    needed = 5 * (1 + 2 * n_aircraft)
    assert pipeline.labeller.samples.n_parameters() == 1 + 2 * n_aircraft
    assert samples_before < needed <= len(pipeline.labeller.samples)
