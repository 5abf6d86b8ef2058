"""The track-start grid posterior: it finds a transmitter heard by spread receivers, stays
wide when the receivers are clustered, its windows skip what was tried, and longer spans are
offered when the shortest leaves the posterior too broad."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from ridsafe.common.errors import FieldValueError
from ridsafe.common.pathloss import received_power_dbm
from ridsafe.gcs.initiation.grid import grid_posterior, init_windows, spread_m
from ridsafe.gcs.localisation.gaussian_sum import start
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import PipelineConfig, TrackConfig
from tests.gcs.claims import noisy_claim as _claim
from tests.gcs.claims import observed_claim


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


def test_longer_spans_are_offered_after_the_shorter_at_each_newest_claim() -> None:
    rng = np.random.default_rng(4)
    rx = rng.uniform(-500, 500, (6, 3))
    claims = [_claim(float(t), np.zeros(3), rx, rng) for t in range(10)]
    windows = init_windows(claims, 4, spans_s=(2.5, 5.0, 8.0))
    sizes = [(w[-1].t_s, len(w)) for w in windows]
    # newest claim t: claims within [t - span, t]; a span that adds no claim is not repeated
    assert sizes[:8] == [(0, 1), (1, 2), (2, 3), (3, 3), (3, 4), (4, 3), (4, 5), (5, 3)]
    assert sizes[-3:] == [(9, 3), (9, 6), (9, 9)]
    assert init_windows(claims, 4) == init_windows(claims, 4, spans_s=(2.5,))


def _moving_receivers_with_errors_that_repeat(seed: int) -> list[ObservedClaim]:
    """A still 20 dBm transmitter heard once a second for 9 s by six aircraft flying apart at
    8 m/s, the RSSI errors (6 dB) drawn anew only every 4 s: three claims in a row are worth
    about one, but the geometry changes over the nine."""
    rng = np.random.default_rng(seed)
    start = np.column_stack((rng.uniform(-300, 300, (6, 2)), rng.uniform(30, 90, 6)))
    heading = rng.uniform(0, 2 * np.pi, 6)
    velocity = 8.0 * np.column_stack((np.cos(heading), np.sin(heading), np.zeros(6)))
    p = np.array([100.0, -50.0, 60.0])
    claims, error = [], np.zeros(6)
    for t in range(9):
        if t % 4 == 0:
            error = rng.normal(0.0, 6.0, 6)
        rx = start + velocity * t
        rssi = received_power_dbm(20.0, np.linalg.norm(rx - p, axis=1)) + error
        claims.append(observed_claim("S", float(t), p, rx, rssi))
    return claims


def test_a_track_starts_from_a_longer_span_when_the_shortest_is_too_broad() -> None:
    """Oracle: the grid posterior of the last three claims is wider than the start's 150 m,
    that of all nine is not (computed here); for the window ending at the last claim (the
    earlier ones tried before), with only the 2.5 s span no track starts, with an 8 s one
    offered it starts on all nine claims."""
    claims = _moving_receivers_with_errors_that_repeat(0)
    alts = (20.0, 60.0, 100.0)
    assert spread_m(grid_posterior(claims[-3:], alts, 6.0)) > 150.0
    assert spread_m(grid_posterior(claims, alts, 6.0)) < 150.0
    base = PipelineConfig(rssi_sigma_db=6.0)
    assert start(claims, base, after_s=7.5) is None
    longer = dataclasses.replace(
        base, tracks=dataclasses.replace(base.tracks, init_spans_s=(2.5, 8.0))
    )
    started = start(claims, longer, after_s=7.5)
    assert started is not None and started[1] == len(claims)


@pytest.mark.parametrize(
    ("spans", "message"),
    [((), "one or more"), ((5.0, 2.5), "ascending"), ((0.0,), "> 0"), ((2.5, 12.0), "kept")],
)
def test_bad_start_spans_are_refused_naming_the_key(spans: tuple[float, ...], message: str) -> None:
    with pytest.raises(FieldValueError, match=f"init_spans_s.*{message}"):
        PipelineConfig(tracks=TrackConfig(init_spans_s=spans))
