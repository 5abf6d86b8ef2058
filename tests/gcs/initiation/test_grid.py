"""The track-start grid posterior: it finds a transmitter heard by spread receivers, stays
wide when the receivers are clustered, and its windows skip what was tried."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ridsafe.gcs.initiation.grid import grid_posterior, init_windows, spread_m
from tests.gcs.claims import noisy_claim as _claim


def test_grid_posterior_finds_the_transmitter() -> None:
    rng = np.random.default_rng(1)
    rx = np.column_stack((rng.uniform(-500, 500, (12, 2)), rng.uniform(30, 100, 12)))
    p = np.array([120.0, -200.0, 60.0])
    claims = [_claim(t, p, rx, rng, 0.5) for t in (0.0, 1.0, 2.0)]
    seeds = grid_posterior(claims, (20.0, 60.0, 100.0), 1.0)
    assert sum(s.weight for s in seeds) == pytest.approx(1.0)
    best = max(seeds, key=lambda s: s.weight)
    assert np.linalg.norm(best.p_xy_m - p[:2]) < 40.0
    assert best.tx_power_dbm == pytest.approx(20.0, abs=1.5)
    assert spread_m(seeds) < 60.0


def test_clustered_receivers_leave_a_wide_grid_posterior() -> None:
    rng = np.random.default_rng(2)
    sites = np.array([[-350.0, -350.0, 0.0], [350.0, -350.0, 0.0], [0.0, 380.0, 0.0]])
    rx = np.repeat(sites, 3, axis=0) + np.r_[rng.uniform(-3, 3, (9, 2)).T, [np.zeros(9)]].T
    claims = [_claim(t, np.array([-450.0, 120.0, 60.0]), rx, rng) for t in (0.0, 1.0)]
    seeds = grid_posterior(claims, (20.0, 60.0, 100.0), 1.0)
    assert spread_m(seeds) > 150.0  # several modes along a ridge, none dominant
    assert len(seeds) > 2 and max(s.weight for s in seeds) < 0.5


def test_init_windows_span_and_skip_what_was_tried() -> None:
    rng = np.random.default_rng(3)
    rx = rng.uniform(-500, 500, (6, 3))
    claims = [_claim(t, np.zeros(3), rx, rng) for t in (0.0, 1.0, 2.0, 3.0, 4.0)]
    windows = init_windows(claims, 4)
    assert [len(w) for w in windows] == [1, 2, 3, 3, 3]
    assert [w[-1].t_s for w in init_windows(claims, 4, after_s=2.5)] == [3.0, 4.0]


def test_a_small_noise_std_drops_the_modes_whose_mass_underflows() -> None:
    # At 0.05 dB every mode but the best is thousands of cost units worse: their weight
    # underflows to 0, and a 0-weight mode with NaN moments made the spread NaN, which let
    # any window pass the tight-posterior check.
    rng = np.random.default_rng(0)
    rx = np.column_stack((rng.uniform(-500, 500, (12, 2)), rng.uniform(30, 100, 12)))
    p = np.array([120.0, -200.0, 60.0])
    claims = [_claim(t, p, rx, rng, 0.05) for t in (0.0, 1.0, 2.0, 3.0, 4.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no 0 / 0 on the way
        seeds = grid_posterior(claims, (20.0, 60.0, 100.0), 0.05)
    assert all(s.weight > 0 and np.isfinite(s.cov_xy_m2).all() for s in seeds)
    assert sum(s.weight for s in seeds) == pytest.approx(1.0)
    assert np.linalg.norm(max(seeds, key=lambda s: s.weight).p_xy_m - p[:2]) < 20.0
    assert np.isfinite(spread_m(seeds)) and spread_m(seeds) < 20.0
