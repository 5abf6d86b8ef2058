"""Tests for ridsafe.common.pathloss: hand-computed values, inverses, clamping, broadcasting."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ridsafe.common.pathloss import (
    DETECTOR_LOSS_AT_1M_DB,
    LOSS_AT_1M_2400MHZ_DB,
    MIN_DISTANCE_M,
    distance_m_from_power,
    implied_tx_power_dbm,
    loss_at_1m_db,
    received_power_dbm,
)


def paper_equation_dbm(pt_dbm: float, d_m: float, f_mhz: float) -> float:
    """The paper's eq. (8) literally: d in km, f in MHz, constant 32.44."""
    return pt_dbm - 20.0 * math.log10(d_m / 1000.0) - 20.0 * math.log10(f_mhz) - 32.44


def test_constants() -> None:
    # 20 log10(2400) = 67.6042; + 32.44 - 60 = 40.0442
    assert pytest.approx(40.0442, abs=1e-4) == LOSS_AT_1M_2400MHZ_DB
    assert DETECTOR_LOSS_AT_1M_DB == 40.04
    assert float(loss_at_1m_db(2400.0)) == LOSS_AT_1M_2400MHZ_DB
    assert float(loss_at_1m_db(5800.0)) == pytest.approx(47.7086, abs=1e-4)


@pytest.mark.parametrize(
    ("pt", "d", "f", "expected"),
    [
        (20.0, 100.0, 2400.0, -60.0442),  # 20 - 40 - 40.0442
        (20.0, 1000.0, 2400.0, -80.0442),
        (10.0, 1.0, 2400.0, -30.0442),
        (20.0, 1000.0, 5800.0, -87.7086),  # 20 - 0 - 75.2686 - 32.44
        (0.0, 50.0, 915.0, -65.6478),  # 0 + 26.0206 - 59.2284 - 32.44
    ],
)
def test_hand_computed_values(pt: float, d: float, f: float, expected: float) -> None:
    got = float(received_power_dbm(pt, d, f))
    assert got == pytest.approx(expected, abs=1e-4)
    assert got == pytest.approx(paper_equation_dbm(pt, d, f), abs=1e-9)


def test_six_db_per_doubling_of_distance() -> None:
    pr = received_power_dbm(20.0, np.array([100.0, 200.0, 400.0]))
    np.testing.assert_allclose(np.diff(pr), -20.0 * math.log10(2.0), atol=1e-12)


def test_small_distances_are_clamped_and_negative_ones_rejected() -> None:
    at_1m = float(received_power_dbm(20.0, MIN_DISTANCE_M))
    assert float(received_power_dbm(20.0, 0.0)) == at_1m
    assert float(received_power_dbm(20.0, 0.3)) == at_1m
    assert float(implied_tx_power_dbm(-20.0, 0.0)) == pytest.approx(-20.0 + 40.04)
    assert math.isnan(float(received_power_dbm(20.0, math.nan)))
    with pytest.raises(ValueError, match="distance_m must be >= 0"):
        received_power_dbm(20.0, [10.0, -1.0])
    with pytest.raises(ValueError, match="frequency_mhz must be > 0"):
        received_power_dbm(20.0, 10.0, 0.0)
    # a power above the 1 m level means "closer than the model resolves"
    assert float(distance_m_from_power(0.0, 20.0)) == MIN_DISTANCE_M


@given(
    d=st.floats(1.0, 1e5),
    pt=st.floats(-20.0, 30.0),
    f=st.floats(100.0, 6000.0),
)
def test_distance_inverts_received_power(d: float, pt: float, f: float) -> None:
    pr = received_power_dbm(pt, d, f)
    assert float(distance_m_from_power(pr, pt, f)) == pytest.approx(d, rel=1e-9)


@given(d=st.floats(1.0, 1e5), pt=st.floats(-20.0, 30.0))
def test_implied_tx_power_inverts_received_power(d: float, pt: float) -> None:
    rssi = received_power_dbm(pt, d)
    exact = float(implied_tx_power_dbm(rssi, d, LOSS_AT_1M_2400MHZ_DB))
    assert exact == pytest.approx(pt, abs=1e-9)
    # the detectors' rounded constant reads 0.0042 dB low
    rounded = float(implied_tx_power_dbm(rssi, d))
    assert rounded - pt == pytest.approx(DETECTOR_LOSS_AT_1M_DB - LOSS_AT_1M_2400MHZ_DB, abs=1e-9)


def test_spoofed_claim_implies_inconsistent_powers() -> None:
    """One transmission, three receivers: the true position implies one Pt, a false one not."""
    tx_true = np.array([0.0, 0.0, 50.0])
    tx_claimed = tx_true + np.array([50.0, 50.0, 0.0])
    receivers = np.array([[200.0, 0.0, 60.0], [-150.0, 80.0, 40.0], [0.0, -300.0, 70.0]])
    rssi = received_power_dbm(17.0, np.linalg.norm(receivers - tx_true, axis=1))
    honest = implied_tx_power_dbm(rssi, np.linalg.norm(receivers - tx_true, axis=1))
    spoofed = implied_tx_power_dbm(rssi, np.linalg.norm(receivers - tx_claimed, axis=1))
    assert np.ptp(honest) < 1e-9
    assert np.ptp(spoofed) > 1.0


def test_vectorised_and_broadcast() -> None:
    distances = np.array([[1.0], [10.0], [100.0]])  # (3, 1)
    powers = np.array([0.0, 10.0, 20.0, 30.0])  # (4,)
    pr = received_power_dbm(powers, distances)
    assert pr.shape == (3, 4)
    for i, d in enumerate(distances[:, 0]):
        for j, pt in enumerate(powers):
            assert pr[i, j] == float(received_power_dbm(pt, d))
    back = distance_m_from_power(pr, powers)
    np.testing.assert_allclose(back, np.broadcast_to(distances, (3, 4)), rtol=1e-12)
    freqs = np.array([915.0, 2400.0, 5800.0])
    assert received_power_dbm(20.0, 100.0, freqs).shape == (3,)
