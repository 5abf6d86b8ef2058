"""The radio's realism options (``RadioConfig``): each against an independent formula or
seeded statistics, each seeded, and each off by default.

Oracles: the log-distance and two-ray far-field formulas re-derived here, the dipole's
broadside gain, chi-square / normal bounds on the per-run draws (seeded, false-alarm
probability far below 1e-4), scipy's Rice distribution for the fading, and a reference run
of the default channel from the same generator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy import stats

from ridsafe.common.scenario import RadioConfig
from ridsafe.sim_backend.radio import RadioChannel, Transmission, body_z_axis

FloatArray = NDArray[np.float64]
HEAR_ALL_DBM = -400.0
Z_BOUND = 4.5


def _channel(n: int, seed: int = 0, **radio: object) -> RadioChannel:
    kwargs: dict[str, object] = {"shadowing_sigma_db": 0.0, "sensitivity_dbm": HEAR_ALL_DBM}
    kwargs.update(radio)
    return RadioChannel(RadioConfig(**kwargs), [20.0] * n, np.random.default_rng(seed))  # type: ignore[arg-type]


def _rssi_matrix(ch: RadioChannel, p: FloatArray, euler: FloatArray | None = None) -> FloatArray:
    """(sender, receiver) RSSI of one transmission by every vehicle (diagonal NaN)."""
    n = p.shape[0]
    out = np.full((n, n), np.nan)
    for s in range(n):
        for rx in ch.deliver([Transmission(0.0, s, b"x")], p, euler):
            out[s, rx.receiver] = rx.rssi_dbm
    return out


def _line(n: int, spacing_m: float = 100.0, z_m: float = 50.0) -> FloatArray:
    return np.column_stack((np.arange(n) * spacing_m, np.zeros(n), np.full(n, z_m)))


@pytest.mark.parametrize("exponent", [2.0, 2.5, 3.0, 3.7])
def test_log_distance_exponent_matches_the_formula(exponent: float) -> None:
    p = _line(3, 137.0)
    rssi = _rssi_matrix(_channel(3, path_loss_exponent=exponent), p)
    l1 = 20.0 * math.log10(2400.0) + 32.44 - 60.0
    for d_index, d_m in ((1, 137.0), (2, 274.0)):
        expected = 20.0 - l1 - 10.0 * exponent * math.log10(d_m)
        assert rssi[0, d_index] == pytest.approx(expected, abs=1e-9)


def test_two_ray_far_field_falls_at_40_db_per_decade() -> None:
    """Beyond the crossover 4 pi h_t h_r / lambda (here 100 m for antennas 1 m up) the two
    rays give |1 - exp(-j phi)|^2 ~ phi^2, phi = 4 pi h_t h_r / (lambda d): 20 log10(phi)."""
    wavelength_m = 299_792_458.0 / 2.4e9
    for d_m in (1000.0, 2000.0):
        p = np.array([[0.0, 0.0, 0.7], [d_m, 0.0, 0.7]])  # + antenna_height_m 0.3 = 1 m
        with_ground = _rssi_matrix(_channel(2, ground_reflection=True), p)[0, 1]
        direct = _rssi_matrix(_channel(2), p)[0, 1]
        phi = 4.0 * math.pi * 1.0 * 1.0 / (wavelength_m * d_m)
        assert with_ground - direct == pytest.approx(20.0 * math.log10(phi), abs=0.05)


def test_two_ray_is_the_coherent_sum_of_two_paths() -> None:
    wavelength_m = 299_792_458.0 / 2.4e9
    p = np.array([[0.0, 0.0, 59.7], [412.0, -77.0, 29.7]])
    gain = (
        _rssi_matrix(_channel(2, ground_reflection=True), p)[0, 1]
        - _rssi_matrix(_channel(2), p)[0, 1]
    )
    x = math.hypot(412.0, 77.0)
    d_los, d_ref = math.hypot(x, 30.0), math.hypot(x, 90.0)
    field = 1.0 - (d_los / d_ref) * np.exp(-2j * math.pi * (d_ref - d_los) / wavelength_m)
    assert gain == pytest.approx(20.0 * math.log10(abs(field)), abs=1e-6)


def test_two_ray_nulls_and_peaks_along_a_track() -> None:
    """Walking the receiver out, the gain swings between about +6 dB and deep fades."""
    gains = []
    for x in np.linspace(50.0, 800.0, 400):
        p = np.array([[0.0, 0.0, 60.0], [x, 0.0, 40.0]])
        with_ground = _rssi_matrix(_channel(2, ground_reflection=True), p)[0, 1]
        gains.append(with_ground - _rssi_matrix(_channel(2), p)[0, 1])
    assert max(gains) == pytest.approx(6.0, abs=0.5)
    assert min(gains) < -15.0


def test_dipole_gain_depends_on_attitude() -> None:
    p = _line(2)
    level = np.zeros((2, 3))
    rssi_level = _rssi_matrix(_channel(2, antenna="dipole"), p, level)[0, 1]
    rssi_iso = _rssi_matrix(_channel(2), p, level)[0, 1]
    assert rssi_level - rssi_iso == pytest.approx(2 * 10 * math.log10(1.641), abs=1e-3)
    # Sender pitched 90 deg about y: its dipole axis points along x, at the receiver: a null.
    pitched = np.array([[0.0, math.pi / 2, 0.0], [0.0, 0.0, 0.0]])
    rssi_pitched = _rssi_matrix(_channel(2, antenna="dipole"), p, pitched)[0, 1]
    assert rssi_pitched - rssi_iso == pytest.approx(10 * math.log10(1.641) - 20.0, abs=1e-3)
    # A 30 deg bank loses a little toward a neighbour abeam.
    banked = np.array([[math.radians(30.0), 0.0, 0.0], [0.0, 0.0, 0.0]])
    p_abeam = np.array([[0.0, 0.0, 50.0], [0.0, 100.0, 50.0]])
    loss = (
        _rssi_matrix(_channel(2, antenna="dipole"), p_abeam, level)[0, 1]
        - _rssi_matrix(_channel(2, antenna="dipole"), p_abeam, banked)[0, 1]
    )
    assert 0.3 < loss < 3.0


def test_body_z_axis_is_up_when_level_and_unit_length() -> None:
    rng = np.random.default_rng(1)
    euler = rng.uniform(-1.0, 1.0, (50, 3))
    axes = body_z_axis(euler)
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0)
    np.testing.assert_allclose(body_z_axis(np.zeros((1, 3))), [[0.0, 0.0, 1.0]])


@pytest.mark.parametrize("field", ["receiver_bias_sigma_db", "tx_power_sigma_db"])
def test_per_run_offsets_have_the_configured_spread_and_stay_fixed(field: str) -> None:
    n, sigma = 2000, 3.0
    ch = _channel(n, seed=4, **{field: sigma})
    draws = ch.rx_bias_db if field == "receiver_bias_sigma_db" else ch.tx_power_dbm - 20.0
    chi2 = float(np.sum(draws**2) / sigma**2)
    assert stats.chi2.ppf(1e-5, n) < chi2 < stats.chi2.ppf(1 - 1e-5, n)
    # Fixed for the run: two transmissions from the same place give the same RSSI.
    p = _line(n, 1.0)
    first = ch.deliver([Transmission(0.0, 1, b"a")], p)
    again = ch.deliver([Transmission(1.0, 1, b"a")], p)
    assert [r.rssi_dbm for r in first] == [r.rssi_dbm for r in again]
    # Seeded: the same seed draws the same, another seed another.
    same = _channel(n, seed=4, **{field: sigma})
    other = _channel(n, seed=5, **{field: sigma})
    np.testing.assert_array_equal(same.rx_bias_db, ch.rx_bias_db)
    np.testing.assert_array_equal(same.tx_power_dbm, ch.tx_power_dbm)
    assert not np.array_equal(other.rx_bias_db, ch.rx_bias_db) or not np.array_equal(
        other.tx_power_dbm, ch.tx_power_dbm
    )


def test_correlated_shadowing_is_fixed_when_still_and_decorrelates_with_motion() -> None:
    n, sigma, d_corr = 400, 4.0, 50.0
    ch = _channel(n, seed=2, shadowing_sigma_db=sigma, shadowing_decorrelation_m=d_corr)
    rng = np.random.default_rng(3)
    p = np.column_stack((rng.uniform(0, 5000, n), rng.uniform(0, 5000, n), np.full(n, 50.0)))
    base = ch.mean_rssi_dbm(0, p)
    s1 = np.array([r.rssi_dbm for r in ch.deliver([Transmission(0, 0, b"")], p)]) - base[1:]
    s1_again = np.array([r.rssi_dbm for r in ch.deliver([Transmission(0, 0, b"")], p)]) - base[1:]
    np.testing.assert_allclose(s1_again, s1)  # nobody moved: rho = 1
    chi2 = float(np.sum(s1**2) / sigma**2)
    assert stats.chi2.ppf(1e-5, n - 1) < chi2 < stats.chi2.ppf(1 - 1e-5, n - 1)
    # Reciprocity: r -> 0 sees the same shadowing as 0 -> r.
    back = ch.deliver([Transmission(0, 5, b"")], p)
    to_zero = next(r.rssi_dbm for r in back if r.receiver == 0)
    assert to_zero - ch.mean_rssi_dbm(5, p)[0] == pytest.approx(s1[4])
    # Every receiver moves d_corr: the correlation with the old values is exp(-1).
    moved = p + np.array([d_corr, 0.0, 0.0]) * np.r_[0.0, np.ones(n - 1)][:, None]
    s2 = np.array([r.rssi_dbm for r in ch.deliver([Transmission(0, 0, b"")], moved)])
    s2 = s2 - ch.mean_rssi_dbm(0, moved)[1:]
    rho = float(np.corrcoef(s1, s2)[0, 1])
    assert abs(rho - math.exp(-1.0)) < Z_BOUND / math.sqrt(n)


def test_rician_fading_follows_the_rice_distribution() -> None:
    n, k_db = 4000, 6.0
    ch = _channel(n + 1, seed=7, fading="rician", rician_k_db=k_db)
    p = _line(n + 1, 0.0)  # everyone 1 m apart or closer: clamped distance, same mean
    p[:, 0] = np.r_[0.0, np.full(n, 10.0)]
    fading_db = np.array([r.rssi_dbm for r in ch.deliver([Transmission(0, 0, b"")], p)])
    fading_db -= ch.mean_rssi_dbm(0, p)[1:]
    k = 10 ** (k_db / 10)
    envelope = 10 ** (fading_db / 20)
    rice = stats.rice(b=math.sqrt(2 * k), scale=math.sqrt(0.5 / (k + 1)))
    assert stats.kstest(envelope, rice.cdf).pvalue > 1e-4
    assert float(np.mean(envelope**2)) == pytest.approx(1.0, abs=Z_BOUND * 0.6 / math.sqrt(n))


def test_rssi_resolution_rounds_the_reported_value() -> None:
    p = _line(5, 73.3)
    exact = _rssi_matrix(_channel(5), p)
    rounded = _rssi_matrix(_channel(5, rssi_resolution_db=1.0), p)
    mask = ~np.isnan(exact)
    np.testing.assert_array_equal(rounded[mask], np.round(exact[mask]))
    half = _rssi_matrix(_channel(5, rssi_resolution_db=0.5), p)
    assert np.all(np.abs(half[mask] * 2 - np.round(half[mask] * 2)) < 1e-9)


def test_defaults_draw_exactly_as_before() -> None:
    """With the new options at their defaults the channel draws from the generator it is
    given, in the documented order, and nothing else: a reference re-implementation."""
    p = _line(4, 120.0)
    ch = RadioChannel(
        RadioConfig(packet_loss_probability=0.2), [20.0] * 4, np.random.default_rng(9)
    )
    got = ch.deliver([Transmission(0, s, b"") for s in (0, 2, 3)], p)
    ref_rng = np.random.default_rng(9)
    expected = []
    for s in (0, 2, 3):
        d = np.linalg.norm(p - p[s], axis=1)
        rssi = 20.0 - 20.0 * np.log10(np.maximum(d, 1.0)) - (20 * math.log10(2400.0) + 32.44 - 60)
        rssi = rssi + ref_rng.normal(0.0, 1.0, 4)
        kept = ref_rng.random(4) >= 0.2
        expected += [(r, rssi[r]) for r in range(4) if r != s and kept[r]]
    assert [r.receiver for r in got] == [r for r, _ in expected]
    assert [r.rssi_dbm for r in got] == pytest.approx([v for _, v in expected], abs=1e-9)


def test_new_options_leave_the_default_stream_alone() -> None:
    """The i.i.d. shadowing and loss draws are the same with or without the per-run offsets
    and fading: those draw from child generators."""
    p = _line(6, 90.0)
    plain = RadioChannel(RadioConfig(), [20.0] * 6, np.random.default_rng(11))
    extra = RadioChannel(
        RadioConfig(receiver_bias_sigma_db=2.0, tx_power_sigma_db=1.0, fading="rician"),
        [20.0] * 6,
        np.random.default_rng(11),
    )
    a = plain.deliver([Transmission(0, 1, b"")], p)
    b = extra.deliver([Transmission(0, 1, b"")], p)
    residual = np.array([y.rssi_dbm - x.rssi_dbm for x, y in zip(a, b, strict=True)])
    offsets = (extra.rx_bias_db + extra.tx_power_dbm[1] - 20.0)[[r.receiver for r in a]]
    # What remains after the fixed offsets is the fading alone: not the shadowing again.
    assert np.all(np.abs(residual - offsets) < 15.0)
    assert plain._rng.random() == extra._rng.random()
