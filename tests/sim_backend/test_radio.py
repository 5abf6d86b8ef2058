"""The simulated RID radio channel against the paper's path-loss equation and seeded statistics.

Oracles: the free-space equation re-derived here (d in km, f in MHz, constant 32.44, never the
module's function); an independent re-implementation of the documented draw order (per
transmission: N shadowing values, then N loss draws); and Monte-Carlo bounds (binomial for packet
loss, chi-square for the shadowing variance) with seeded generators, so each test is
deterministic and its bound has a false-alarm probability far below 1e-4.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy import stats

from ridsafe.common.scenario import RadioConfig
from ridsafe.sim_backend.radio import RadioChannel, Reception, Transmission

FloatArray = NDArray[np.float64]

# Far below anything the tests produce: every reception is above sensitivity.
HEAR_ALL_DBM = -400.0
# Half-width of a two-sided Monte-Carlo bound, in standard deviations (p ~ 7e-6).
Z_BOUND = 4.5


def fspl_dbm(pt_dbm: float, d_m: float, f_mhz: float) -> float:
    """The paper's eq. (8) as printed: Pr = Pt - 20 log10(d_km) - 20 log10(f_MHz) - 32.44."""
    return pt_dbm - 20.0 * math.log10(d_m / 1000.0) - 20.0 * math.log10(f_mhz) - 32.44


def _channel(
    seed: int = 0,
    tx_power_dbm: list[float] | None = None,
    n: int = 2,
    **radio: Any,
) -> RadioChannel:
    config = dataclasses.replace(
        RadioConfig(shadowing_sigma_db=0.0, sensitivity_dbm=HEAR_ALL_DBM), **radio
    )
    powers = tx_power_dbm if tx_power_dbm is not None else [20.0] * n
    return RadioChannel(config, powers, np.random.default_rng(seed))


def _ring(n: int, radius_m: float, z_m: float = 30.0) -> FloatArray:
    """Vehicle 0 at the origin and ``n`` receivers on a horizontal circle about it."""
    angles = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    ring = np.column_stack((radius_m * np.cos(angles), radius_m * np.sin(angles), np.full(n, z_m)))
    return np.vstack((np.array([[0.0, 0.0, z_m]]), ring))


# Four vehicles, no two at the same distance from any third, transmit powers all different,
# so using the receiver's power, a wrong axis or a swapped index changes some value.
GEOMETRY = np.array(
    [[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [30.0, -40.0, 120.0], [-700.0, 250.0, 60.0]]
)
POWERS_DBM = [20.0, 7.0, -3.0, 14.0]


@pytest.mark.parametrize("f_mhz", [2400.0, 915.0, 5800.0])
def test_rssi_without_shadowing_is_the_free_space_equation(f_mhz: float) -> None:
    channel = _channel(tx_power_dbm=POWERS_DBM, frequency_mhz=f_mhz)
    transmissions = [Transmission(0.5, s, bytes([s]) * 25) for s in range(4)]
    receptions = channel.deliver(transmissions, GEOMETRY)
    assert len(receptions) == 12
    heard = {(rx.transmission.sender, rx.receiver): rx for rx in receptions}
    for s in range(4):
        for r in range(4):
            if r == s:
                continue
            rx = heard[s, r]
            assert rx.transmission is transmissions[s]
            d_m = math.dist(GEOMETRY[s], GEOMETRY[r])
            assert rx.rssi_dbm == pytest.approx(fspl_dbm(POWERS_DBM[s], d_m, f_mhz), abs=1e-9)


def test_rssi_at_2400_mhz_is_pt_minus_20log_d_minus_40_04() -> None:
    # DESIGN.md section 6: with d in metres, Pr = Pt - 20 log10(d_m) - 40.04 (40.0442 exactly).
    positions = np.array([[0.0, 0.0, 0.0], [0.0, 250.0, 0.0]])
    (rx,) = _channel().deliver([Transmission(0.0, 1, b"x" * 25)], positions)
    assert rx.receiver == 0
    assert rx.rssi_dbm == pytest.approx(20.0 - 20.0 * math.log10(250.0) - 40.04, abs=5e-3)


def test_distances_below_one_metre_are_clamped_to_one_metre() -> None:
    positions = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    (rx,) = _channel().deliver([Transmission(0.0, 0, b"x" * 25)], positions)
    assert rx.rssi_dbm == pytest.approx(fspl_dbm(20.0, 1.0, 2400.0), abs=1e-9)


def test_the_sender_never_hears_itself_even_when_colocated() -> None:
    n = 5
    channel = _channel(n=n)
    transmissions = [Transmission(1.0, s, b"x" * 25) for s in range(n)]
    receptions = channel.deliver(transmissions, np.zeros((n, 3)))
    assert all(rx.receiver != rx.transmission.sender for rx in receptions)
    pairs = sorted((rx.transmission.sender, rx.receiver) for rx in receptions)
    assert pairs == [(s, r) for s in range(n) for r in range(n) if r != s]
    assert (channel.delivered, channel.below_sensitivity, channel.lost) == (n * (n - 1), 0, 0)


def test_receivers_below_sensitivity_are_not_delivered() -> None:
    # Pt 20 dBm at 2400 MHz: 100 m -60.0, 300 m -69.6, 1 km -80.0, 5 km -94.0, 20 km -106.1
    distances_m = [100.0, 300.0, 1000.0, 5000.0, 20000.0]
    positions = np.array([[0.0, 0.0, 0.0]] + [[d, 0.0, 0.0] for d in distances_m])
    channel = _channel(n=6, sensitivity_dbm=-85.0)
    receptions = channel.deliver([Transmission(0.0, 0, b"x" * 25)], positions)
    assert [rx.receiver for rx in receptions] == [1, 2, 3]
    assert all(rx.rssi_dbm >= -85.0 for rx in receptions)
    assert (channel.delivered, channel.below_sensitivity, channel.lost) == (3, 2, 0)


@pytest.mark.parametrize("p_loss", [0.1, 0.5, 0.9])
def test_packet_loss_delivers_a_binomial_fraction(p_loss: float) -> None:
    receivers, n_tx = 40, 500
    positions = _ring(receivers, 50.0)
    channel = _channel(seed=17, n=receivers + 1, packet_loss_probability=p_loss)
    tx = [Transmission(0.01 * k, 0, b"x" * 25) for k in range(n_tx)]
    receptions = channel.deliver(tx, positions)
    trials = receivers * n_tx
    expected = trials * (1.0 - p_loss)
    bound = Z_BOUND * math.sqrt(trials * p_loss * (1.0 - p_loss))
    assert abs(len(receptions) - expected) <= bound
    assert channel.delivered == len(receptions)
    assert channel.lost == trials - len(receptions)
    assert channel.below_sensitivity == 0


@pytest.mark.parametrize("sigma_db", [1.0, 6.0])
def test_shadowing_has_zero_mean_and_the_configured_sigma(sigma_db: float) -> None:
    receivers, n_tx = 50, 400
    rng = np.random.default_rng(3)
    # receivers 100 m to 2.1 km above the sender: all farther than the 1 m clamp
    around = rng.uniform(-1000.0, 1000.0, (receivers, 3)) + np.array([0.0, 0.0, 1100.0])
    positions = np.vstack((np.zeros((1, 3)), around))
    channel = _channel(seed=23, n=receivers + 1, shadowing_sigma_db=sigma_db)
    receptions = channel.deliver([Transmission(0.0, 0, b"x" * 25)] * n_tx, positions)
    assert len(receptions) == receivers * n_tx
    noiseless = {
        r: fspl_dbm(20.0, math.dist(positions[0], positions[r]), 2400.0)
        for r in range(1, receivers + 1)
    }
    residual = np.array([rx.rssi_dbm - noiseless[rx.receiver] for rx in receptions])
    n = residual.size
    # Mean near 0: the noiseless value is the mean.
    assert abs(residual.mean()) <= Z_BOUND * sigma_db / math.sqrt(n)
    # Known-mean variance: sum(r^2) / sigma^2 ~ chi2(n).
    statistic = float(np.sum(residual**2)) / sigma_db**2
    assert stats.chi2.ppf(1e-5, n) <= statistic <= stats.chi2.ppf(1.0 - 1e-5, n)
    # Independent per receiver: the spread across receivers within one transmission is also
    # sigma (a draw shared by all receivers of a transmission would make it zero).
    per_tx = residual.reshape(n_tx, receivers)
    within = float(np.sum((per_tx - per_tx.mean(axis=1, keepdims=True)) ** 2)) / sigma_db**2
    dof = n_tx * (receivers - 1)
    assert stats.chi2.ppf(1e-5, dof) <= within <= stats.chi2.ppf(1.0 - 1e-5, dof)


def test_sensitivity_applies_to_the_shadowed_rssi() -> None:
    # Receivers exactly where the noiseless RSSI equals the sensitivity: about half hear it,
    # and every delivered RSSI (with its noise) is at or above the sensitivity.
    receivers, n_tx = 40, 250
    positions = _ring(receivers, 200.0)
    sensitivity = fspl_dbm(20.0, 200.0, 2400.0)
    channel = _channel(seed=5, n=receivers + 1, shadowing_sigma_db=3.0, sensitivity_dbm=sensitivity)
    receptions = channel.deliver([Transmission(0.0, 0, b"x" * 25)] * n_tx, positions)
    trials = receivers * n_tx
    assert abs(len(receptions) - trials / 2) <= Z_BOUND * math.sqrt(trials / 4)
    assert all(rx.rssi_dbm >= sensitivity for rx in receptions)
    assert channel.below_sensitivity == trials - len(receptions)


def _expected_deliveries(
    seed: int,
    config: RadioConfig,
    powers: list[float],
    transmissions: list[Transmission],
    positions: FloatArray,
) -> tuple[list[Reception], tuple[int, int, int]]:
    """The module docstring's model, written out independently, with its own generator."""
    rng = np.random.default_rng(seed)
    n = int(positions.shape[0])
    out: list[Reception] = []
    delivered = below = lost = 0
    for tx in transmissions:
        noise = rng.normal(0.0, config.shadowing_sigma_db, size=n)
        draws = rng.random(size=n)
        for r in range(n):
            if r == tx.sender:
                continue
            d_m = max(math.dist(positions[tx.sender], positions[r]), 1.0)
            rssi = fspl_dbm(powers[tx.sender], d_m, config.frequency_mhz) + noise[r]
            if rssi < config.sensitivity_dbm:
                below += 1
            elif draws[r] < config.packet_loss_probability:
                lost += 1
            else:
                delivered += 1
                out.append(Reception(r, tx, rssi))
    return out, (delivered, below, lost)


def test_receptions_follow_the_documented_draw_order_exactly() -> None:
    config = RadioConfig(
        frequency_mhz=2400.0,
        shadowing_sigma_db=4.0,
        sensitivity_dbm=-75.0,
        packet_loss_probability=0.25,
    )
    positions = np.array(
        [[0.0, 0.0, 40.0], [120.0, 30.0, 50.0], [-400.0, 900.0, 60.0], [5.0, -250.0, 0.0]]
    )
    powers = [20.0, 12.0, 25.0, 18.0]
    transmissions = [Transmission(0.1 * k, k % 4, bytes([k]) * 25) for k in range(60)]
    channel = RadioChannel(config, powers, np.random.default_rng(99))
    got = channel.deliver(transmissions, positions)
    expected, counters = _expected_deliveries(99, config, powers, transmissions, positions)
    assert [(rx.receiver, rx.transmission) for rx in got] == [
        (rx.receiver, rx.transmission) for rx in expected
    ]
    np.testing.assert_allclose(
        [rx.rssi_dbm for rx in got], [rx.rssi_dbm for rx in expected], atol=1e-9
    )
    assert (channel.delivered, channel.below_sensitivity, channel.lost) == counters
    assert min(counters) > 0  # the case exercises all three outcomes


def _noisy_run(seed: int) -> list[Reception]:
    channel = _channel(
        seed=seed, n=6, shadowing_sigma_db=5.0, packet_loss_probability=0.3, sensitivity_dbm=-70.0
    )
    positions = _ring(5, 150.0)
    return channel.deliver([Transmission(0.2 * k, k % 6, b"x" * 25) for k in range(30)], positions)


def test_the_same_seed_gives_identical_receptions_and_another_seed_different_ones() -> None:
    first, again, other = _noisy_run(11), _noisy_run(11), _noisy_run(12)
    assert first == again
    assert len(first) > 0
    assert first != other
    assert [rx.rssi_dbm for rx in first[:5]] != [rx.rssi_dbm for rx in other[:5]]


def test_counters_add_up_to_every_receiver_of_every_transmission() -> None:
    n, n_tx = 6, 300
    channel = _channel(
        seed=4, n=n, shadowing_sigma_db=8.0, sensitivity_dbm=-72.0, packet_loss_probability=0.2
    )
    positions = np.array(
        [
            [0.0, 0.0, 0.0],
            [90.0, 0.0, 0.0],
            [0.0, 300.0, 0.0],
            [800.0, 0.0, 50.0],
            [0.0, -150.0, 10.0],
            [-40.0, -40.0, 40.0],
        ]
    )
    receptions: list[Reception] = []
    for k in range(n_tx):  # several calls: the counters accumulate
        receptions += channel.deliver([Transmission(0.1 * k, k % n, b"x" * 25)], positions)
    assert channel.delivered == len(receptions)
    assert channel.delivered + channel.below_sensitivity + channel.lost == n_tx * (n - 1)
    assert channel.delivered > 0 and channel.below_sensitivity > 0 and channel.lost > 0
