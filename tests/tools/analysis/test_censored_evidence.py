"""The misses' evidence: the censored likelihood's gradient, its ratio test's null on honest
claims drawn through a censored channel, a liar found by who did not hear it, and the
command on a hand-built log written by the real recorder."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import check_grad, minimize
from scipy.special import log_ndtr
from scipy.stats import norm

from ridsafe.common import topics
from ridsafe.gcs.detection.censored_kernels import censored_nll, log_norm_cdf
from ridsafe.tools.analysis.censored_evidence import (
    CensoredChannel,
    Heard,
    main,
    offset_glrt,
    run_evidence,
    surprisal,
)
from ridsafe.tools.runlog.writer import McapRecorder

CHANNEL = CensoredChannel(exponent=3.0, sigma_db=1.0, floor_dbm=-95.0)
#: P less the 1 m loss: a 20 dBm transmitter at 2.4 GHz, heard down to about 320 m at n = 3.
POWER_DBM = -20.0
#: A 5 x 5 grid of receivers 120 m apart at 50 m, the transmitter near its middle.
RECEIVERS = np.array(
    [[120.0 * i, 120.0 * j, 50.0] for i in range(-2, 3) for j in range(-2, 3)], dtype=np.float64
)


def _draw(true_p: np.ndarray, claimed_p: np.ndarray, rng: np.random.Generator) -> Heard:
    """One transmission from ``true_p`` through ``CHANNEL`` (no packet loss), claimed at
    ``claimed_p``."""
    d = np.maximum(np.linalg.norm(true_p - RECEIVERS, axis=1), 1.0)
    rssi = POWER_DBM - 10.0 * CHANNEL.exponent * np.log10(d)
    rssi = rssi + rng.normal(0.0, CHANNEL.sigma_db, d.shape[0])
    heard = rssi >= CHANNEL.floor_dbm
    return Heard(claimed_p, RECEIVERS, heard, np.where(heard, rssi, math.nan))


def _terms(window: list[Heard]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    diff = np.concatenate([tx.claimed_p_enu_m - tx.rx_p_enu_m for tx in window])
    heard = np.concatenate([tx.heard for tx in window])
    rssi = np.where(heard, np.concatenate([tx.rssi_dbm for tx in window]), 0.0)
    return diff, heard, rssi, np.full(heard.shape[0], CHANNEL.floor_dbm)


def _reference_nll(theta: np.ndarray, window: list[Heard], misses: bool) -> float:
    """The module docstring's likelihood, written with scipy's distributions (up to the
    heard terms' constant log(s sqrt(2 pi)), which the kernel leaves out)."""
    diff, heard, rssi, floor = _terms(window)
    d = np.maximum(np.linalg.norm(diff - theta[:3], axis=1), 1.0)
    mu = theta[3] - 10.0 * CHANNEL.exponent * np.log10(d)
    s, q = CHANNEL.sigma_db, CHANNEL.miss_floor
    value = -np.sum(norm.logpdf(rssi[heard], mu[heard], s) + math.log(s * math.sqrt(2 * math.pi)))
    if misses:
        miss = q + (1.0 - q) * norm.cdf((floor[~heard] - mu[~heard]) / s)
        return float(value - np.sum(np.log(miss)))
    return float(value + np.sum(norm.logsf((floor[heard] - mu[heard]) / s)))


def test_the_compiled_likelihood_and_its_gradient_are_the_equations() -> None:
    rng = np.random.default_rng(1)
    window = [_draw(np.array([30.0, -20.0, 60.0]), np.array([80.0, 30.0, 60.0]), rng)]
    assert 3 <= int(window[0].heard.sum()) < RECEIVERS.shape[0]  # censored
    terms = _terms(window)
    for misses in (True, False):
        sigma = np.full(terms[1].shape[0], CHANNEL.sigma_db)
        args = (*terms, CHANNEL.exponent, sigma, CHANNEL.miss_floor, misses)
        for params in ([0.0, 0.0, 0.0, -20.0], [40.0, -30.0, 5.0, -18.0], [-60, 10, 0, -25]):
            x = np.asarray(params, dtype=np.float64)
            value, grad = censored_nll(x, *args)
            assert value == pytest.approx(_reference_nll(x, window, misses), rel=1e-9)
            err = check_grad(
                lambda p, a=args: censored_nll(p, *a)[0],
                lambda p, a=args: censored_nll(p, *a)[1],
                x,
            )
            assert err < 1e-5 * max(1.0, float(np.linalg.norm(grad)))


def test_log_norm_cdf_holds_in_both_tails() -> None:
    for x in (-200.0, -45.0, -30.5, -29.5, -8.0, -1.0, 0.0, 2.5, 9.0, 40.0):
        assert log_norm_cdf(x) == pytest.approx(float(log_ndtr(x)), rel=1e-9, abs=1e-300)


def test_the_search_finds_the_maximum_a_multi_start_search_finds() -> None:
    """On censored windows of a liar and an honest transmitter, T is at least what
    Nelder-Mead from 9 starts on a 300 m square finds (less a rounding)."""
    rng = np.random.default_rng(5)
    true_p = np.array([-420.0, -300.0, 60.0])
    for claimed_p in (true_p + np.array([50.0, 50.0, 0.0]), true_p):
        window = [_draw(true_p, claimed_p, rng) for _ in range(6)]
        nll = functools.partial(_reference_nll, window=window, misses=True)
        null = minimize(lambda p, f=nll: f(np.array([0.0, 0.0, 0.0, p[0]])), [-20.0])
        best = null.fun
        for x0 in np.linspace(-150.0, 150.0, 3):
            for y0 in np.linspace(-150.0, 150.0, 3):
                start = [x0, y0, 0.0, float(null.x[0])]
                fit = minimize(
                    nll,
                    start,
                    method="Nelder-Mead",
                    options={"maxiter": 2000, "xatol": 1e-2, "fatol": 1e-5},
                )
                best = min(best, fit.fun)
        assert offset_glrt(window, CHANNEL) >= 2.0 * (null.fun - best) - 1e-3


def test_honest_claims_stay_near_the_chi_square_null() -> None:
    """Honest windows (5 transmissions each) through the censored channel: T's mean is about
    3 (chi2_3) and none reaches the detectors' threshold."""
    rng = np.random.default_rng(7)
    statistics = []
    for _ in range(30):
        p = np.append(rng.uniform(-150.0, 150.0, 2), 60.0)
        window = [_draw(p, p, rng) for _ in range(5)]
        statistics.append(offset_glrt(window, CHANNEL))
    assert 1.5 < float(np.mean(statistics)) < 5.0
    assert max(surprisal(t) for t in statistics) < 6.0


def test_a_liar_is_given_away_by_the_receivers_that_did_not_hear_it() -> None:
    """A transmitter beyond the grid's edge, heard by two to four receivers near the floor,
    claiming 70 m further in, where more receivers would have heard it. Over 8 windows of 10
    transmissions the test with the misses is stronger than on the receptions alone in
    every one, and its median crosses the threshold while theirs does not; the same
    transmitter telling the truth stays far below it."""
    true_p = np.array([-420.0, -300.0, 60.0])
    claimed_p = true_p + np.array([50.0, 50.0, 0.0])
    with_misses, received_only, honest = [], [], []
    for seed in range(8):
        rng = np.random.default_rng(seed)
        window = [_draw(true_p, claimed_p, rng) for _ in range(10)]
        assert all(1 <= tx.heard.sum() <= 5 for tx in window)
        with_misses.append(surprisal(offset_glrt(window, CHANNEL)))
        received_only.append(surprisal(offset_glrt(window, CHANNEL, misses=False)))
        truthful = [_draw(true_p, true_p, rng) for _ in range(10)]
        honest.append(surprisal(offset_glrt(truthful, CHANNEL)))
    assert all(m > r for m, r in zip(with_misses, received_only, strict=True))
    assert np.median(with_misses) > 6.0 > np.median(received_only)
    assert max(honest) < 3.0


def _log(path: Path, *, channel: bool, spoofer_hears_dbm: float | None = None) -> Path:
    """Nine receivers at 50 m, the spoofer beyond their corner lying 70 m inward, one
    LOCATION a second heard by those its true position reaches, and the middle receiver's
    own truthful LOCATION; a fitted channel at 2 s. With ``spoofer_hears_dbm``, the
    spoofer's own radio hears that LOCATION at that RSSI too (it reports to no one)."""
    rng = np.random.default_rng(11)
    receivers = RECEIVERS[[6, 7, 8, 11, 12, 13, 16, 17, 18]]
    spoofer_p = np.array([-230.0, -230.0, 60.0])
    offset = [50.0, 50.0, 0.0]
    sysids = [*range(1, receivers.shape[0] + 1), 99]
    positions = np.vstack((receivers, spoofer_p)).tolist()
    meta = {"spoofer": {"sysid": 99, "serial": "X", "offset_enu_m": offset}}
    with McapRecorder(path) as recorder:
        recorder.log(topics.RUN_META, 0.0, meta)
        if channel:
            record = {
                "t_s": 2.0,
                "channel": "fitted",
                "n_samples": 300,
                "exponent": 3.0,
                "sigma_db": 1.0,
                "residual_std_db": None,
                "p_value": None,
            }
            recorder.log(topics.GCS_CHANNEL, 2.0, record)
        for k in range(8):
            t_s = 0.5 + k
            recorder.log(topics.TRUTH, t_s, {"sysid": sysids, "p_enu_m": positions})
            d = np.linalg.norm(spoofer_p - receivers, axis=1)
            rssi = POWER_DBM - 30.0 * np.log10(d) + rng.normal(0.0, 1.0, d.shape[0])
            items = [
                {"sender": 99, "receiver": r, "msg_type": 1, "rssi_dbm": float(z)}
                for r, z in zip(sysids, rssi, strict=False)
                if z >= -95.0
            ]
            honest = receivers[4]  # the middle receiver, sysid 5, transmits too
            d = np.linalg.norm(honest - np.delete(receivers, 4, axis=0), axis=1)
            rssi = POWER_DBM - 30.0 * np.log10(d) + rng.normal(0.0, 1.0, d.shape[0])
            items += [
                {"sender": 5, "receiver": r, "msg_type": 1, "rssi_dbm": float(z)}
                for r, z in zip([1, 2, 3, 4, 6, 7, 8, 9], rssi, strict=True)
                if z >= -95.0
            ]
            if spoofer_hears_dbm is not None:
                items.append(
                    {"sender": 5, "receiver": 99, "msg_type": 1, "rssi_dbm": spoofer_hears_dbm}
                )
            recorder.log(topics.RADIO_RX, t_s, {"items": items})
    return path


def test_the_command_reports_the_crossing_no_earlier_than_the_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _log(tmp_path / "run.mcap", channel=True)
    ev = run_evidence(log, until_s=10.0)
    assert ev.fit_s == 2.0 and ev.crossed_s is not None and ev.heard_by_s is not None
    assert ev.delay_s(ev.crossed_s) == pytest.approx(max(ev.crossed_s, 2.0) - ev.heard_by_s)
    assert main([str(log), "--until-s", "10"]) == 0
    printed = capsys.readouterr().out
    assert 0.0 < ev.honest_max < 6.0  # the middle receiver's own claims, tested
    assert 0.0 < ev.honest_max_received_only < 6.0
    assert "1 runs, tested up to 10 s: delay median / p90 / worst" in printed
    assert "largest honest surprisal on the receptions alone" in printed
    assert str(log) in printed


def test_the_cut_is_what_the_fleet_heard_not_the_spoofer_s_own_radio(tmp_path: Path) -> None:
    """The GCS hears of no reception by the spoofer's radio, so its weakest RSSI sets no
    cut: a log where the spoofer heard something far weaker gives the same evidence."""
    plain = run_evidence(_log(tmp_path / "plain.mcap", channel=True), until_s=10.0)
    heard = _log(tmp_path / "heard.mcap", channel=True, spoofer_hears_dbm=-103.0)
    assert run_evidence(heard, until_s=10.0) == plain


def test_a_log_without_a_fitted_channel_or_a_miss_floor_of_0_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _log(tmp_path / "no_fit.mcap", channel=False)
    assert main([str(log)]) == 2
    assert "no fitted channel" in capsys.readouterr().err
    fitted = _log(tmp_path / "run.mcap", channel=True)
    assert main([str(fitted), "--miss-floor", "0"]) == 2
    assert "miss floor: expected 0 < q < 1, got 0" in capsys.readouterr().err
